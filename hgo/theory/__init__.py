"""Computable theory: conditions and bounds from the papers (Sanfelice & Praly (8)-(15))."""
