"""Sanfelice & Praly (2010): sign-indefinite gain adaptation, notch filter, averaging."""
