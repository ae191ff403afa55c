"""hgo: a research harness for high-gain observer experiments."""
