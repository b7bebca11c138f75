"""``python -m pdmkit`` runs the command-line interface."""

from pdmkit.experiments._cli import main

raise SystemExit(main())
