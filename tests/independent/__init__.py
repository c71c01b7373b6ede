"""An independent reader of ``.nzc`` containers, written from ``docs/format.md``
alone (issue 31): it imports nothing from ``nurbscomp``.  Where it and
``nurbscomp`` disagree, the spec is fixed first."""
