"""Controllers: input u computed from one observer's estimate and the measured outputs."""
