"""Andrieu, Praly & Astolfi (IFAC 2007), dynamic high gains: Contois bioreactor, Figs. 1-2."""
