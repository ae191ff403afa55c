"""Design helpers: gain and parameter choices derived from the papers' design rules."""
