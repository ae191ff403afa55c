"""Plants: dynamics, measured outputs before noise, true state for error computation."""
