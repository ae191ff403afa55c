"""What a run leaves behind: recordings (write, read), metrics tables, run.json and the run
index, figures, console tables. (A regular package like the other layers: mkdocstrings and
setuptools' package discovery skip a folder without ``__init__.py``.)"""
