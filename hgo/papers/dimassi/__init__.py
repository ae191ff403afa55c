"""Dimassi, Hadj Said, Loría & M'Sahli (STA 2019): HGO in cascade with an adaptive observer."""
