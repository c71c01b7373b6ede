"""Tolerance policy on a whole model (DESIGN §2).

The stages, in the order the encoder runs them:

- :mod:`.nets`: which records are coded and how (the per-net search on every
  distinct B-spline surface and curve; coincident curves and sides coded once);
- :mod:`.assembly`: the model the decoder will rebuild from those codes
  (snapped vertices, pinned ends and corners, copies, widened tolerances);
- :mod:`.pcurves`: the pcurves and ranges left for the decoder to compute;
- :mod:`.validity`: which coded records the container may use so that the
  decoded B-rep is as valid as the source: the BRepCheck stage and the
  STEP-reader stage, each remedy a named step on a per-face ladder.
"""
