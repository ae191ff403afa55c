"""Observers: continuous dynamics, discrete logic, the estimate they expose."""
