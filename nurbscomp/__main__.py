"""``python -m nurbscomp``: the same command line as the ``nurbscomp`` script."""

from .cli import main

main()
