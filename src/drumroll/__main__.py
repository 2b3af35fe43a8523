"""``python -m drumroll``: the same as the ``drumroll`` command."""

from drumroll.cli.main import console_main

console_main()
