"""Moreno, *Observer design for a class of nonlinear systems with bad trajectories*."""
