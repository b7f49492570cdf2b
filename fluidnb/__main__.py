"""``python -m fluidnb`` runs the command line."""

from fluidnb.cli import main

raise SystemExit(main())
