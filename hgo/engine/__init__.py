"""Simulation engine: composition of components into one compiled kernel, integrators."""
