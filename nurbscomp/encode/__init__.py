"""Tolerance policy on a whole model (docs/design.md §2).

The stages, in the order the encoder runs them:

- :mod:`.nets`: which records are coded and how (the per-net search on every
  distinct B-spline surface and curve; coincident curves and sides coded once);
- :mod:`.assembly`: the model the decoder will rebuild from those codes
  (snapped vertices, pinned ends and corners, copies, widened tolerances);
- :mod:`.pcurves`: the pcurves and ranges left for the decoder to compute;
- :mod:`.validity`: which coded records the container may use so that the
  decoded B-rep is as valid as the source: the BRepCheck stage and the
  STEP-reader stage, each remedy a named step on a per-face ladder.

Records are keyed by table and row, never by object identity:
:class:`nurbscomp.model.Rec` ``(table, row)``, ``table`` a
:class:`nurbscomp.model.Table` (``SURFACE`` or ``CURVE3D``).  A record is a
distinct object of a table, named by the first row that holds it
(:func:`nurbscomp.model.first_row`): rows holding the same object (written
as COPY rows after the first) share one record, and are coded, kept exact,
tightened and replaced together.  The decoded model keeps the source's rows
(a coded record's decoded version replaces it at every row of it), so the
codes :func:`.assembly.assemble` hands to the container
(``record -> NetCode``) name the rows of both.  Where a record set also
holds the edges that have no 3-D curve (:func:`.nets.edge_records`), those
are ``None``.
"""
