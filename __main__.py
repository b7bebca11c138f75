"""``python -m pdmkit`` runs the command-line interface."""

from pdmkit._entry import main

raise SystemExit(main())
