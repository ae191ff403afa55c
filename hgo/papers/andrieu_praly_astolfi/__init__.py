"""Andrieu, Praly & Astolfi (IFAC 2007), homogeneous observers with dynamic high gains: Contois bioreactor, Figs. 1-2."""
