"""Tolerance policy on a whole model (DESIGN §2).

:mod:`.validity` decides which coded records the container may use so that
the decoded B-rep is as valid as the source: the BRepCheck stage and the
STEP-reader stage, each remedy a named step on a per-face ladder.
"""
