"""``python -m drumroll``: the same as the ``drumroll`` command."""

from drumroll.cli.main import main

raise SystemExit(main())
