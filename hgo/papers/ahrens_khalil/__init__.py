"""Ahrens & Khalil (2008): switched-gain high-gain observer in closed loop (DC motor)."""
