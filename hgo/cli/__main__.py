"""``python -m hgo.cli ...`` is ``hgo ...`` (the console script's entry point, :func:`main`)."""

from hgo.cli import main

raise SystemExit(main())
