"""Tolerance mode on a whole model: code every B-spline surface net, keep the B-rep valid.

:func:`encode_model` runs the per-net search of :mod:`nurbscomp.codec` on each
distinct B-spline or Bezier surface, and returns the model the decoder will
rebuild: the same tables with the *decoded* nets, and with edge and vertex
tolerances widened by the coding error of the faces around them (the curves
and pcurves are still exact, so an edge's distance to its moved surface grows
by at most that face's bound).

3-D B-spline curves are coded the same way (:data:`codec.CURVE_METHODS`).
What this version does not code yet (it stays exact): pcurves, vertices,
analytic geometry, and B-splines under an offset (an offset of a moved
geometry can move by more than its poles did).
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from . import codec
from .model import (
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Derived,
    Geometry,
    Kind,
    RepKind,
    ShapeType,
)
from .serialize import net_abscissae


@dataclass
class LossyReport:
    """What the search chose.

    Attributes
    ----------
    face_method : list of str
        Per face (model order): ``"spatial"``, ``"boundary"`` (the paper's "no
        difference data"), ``"ddmap"``, ``"swept"`` (a swept surface whose
        curve was coded), or ``"exact"``.
    face_bound : ndarray, shape (F,)
        Certified bound per face (0 for exact faces).
    edge_bound : ndarray, shape (E,)
        Certified bound of each edge's 3-D curve.
    surface_bits, curve_bits : float
        Estimated bits of the coded nets (before the entropy stage).
    surface_poles, curve_poles : int
        Poles of the coded nets.
    """

    face_method: list[str]
    face_bound: np.ndarray
    edge_bound: np.ndarray
    surface_bits: float
    surface_poles: int
    curve_bits: float
    curve_poles: int

    def method_counts(self) -> dict[str, int]:
        return dict(collections.Counter(self.face_method))


def _resolve(table: list[Geometry], i: int, through: tuple[Kind, ...]) -> Geometry:
    """The record under row ``i``, following the bases of ``through`` kinds."""
    g = table[i]
    while isinstance(g, Derived) and g.kind in through:
        g = table[g.basis]
    return g


def _offset_bases(table: list[Geometry], offset: Kind, through: tuple[Kind, ...]) -> set[int]:
    """Ids of records under an offset: they must stay exact (an offset of a
    moved geometry moves by more than the poles did)."""
    out: set[int] = set()
    for g in table:
        if isinstance(g, Derived) and g.kind == offset:
            b = table[g.basis]
            while True:
                out.add(id(b))
                if isinstance(b, Derived) and b.kind in (*through, offset):
                    b = table[b.basis]
                else:
                    break
    return out


def below(m: BRepModel, s: int, kind: ShapeType) -> set[int]:
    """Shape indices of type ``kind`` reachable below shape ``s``."""
    out, stack = set(), [s]
    while stack:
        x = stack.pop()
        for c in m.child_shape[m.child_start[x] : m.child_start[x + 1]].tolist():
            if m.shape_type[c] == kind:
                out.add(c)
            elif m.shape_type[c] < kind:
                stack.append(c)
    return out


def _code_table(
    table: list[Geometry],
    tol: float,
    keep: set[int],
    methods_for: Any,
    paper: bool,
    codes: dict[int, codec.NetCode],
) -> tuple[list[Geometry], dict[int, codec.NetCode]]:
    """Code every B-spline record of a table not in ``keep``; return the decoded table.

    Returns the new table and ``id(new record) -> code``.
    """
    new: dict[int, Geometry] = {}
    out: dict[int, codec.NetCode] = {}
    origin = None
    for g in table:
        if id(g) in new or id(g) in keep or not isinstance(g, (BSplineSurface, BSplineCurve)):
            continue
        s, t = net_abscissae(g)
        code = codec.encode_net(g.poles, s, t, tol, methods_for(g), paper=paper, origin=origin)
        net, _ = codec.decode_net(code, g.poles.shape, s, t, tol, origin)
        origin = net.reshape(-1, net.shape[-1])[0]
        rec = replace(g, poles=net)
        new[id(g)] = rec
        out[id(rec)] = code
    codes.update(out)
    return [new.get(id(g), g) for g in table], out


_TRIM_S = (Kind.TRIMMED_SURFACE,)
_TRIM_C = (Kind.TRIMMED_CURVE,)


def encode_model(
    m: BRepModel, tol: float, paper: bool = False
) -> tuple[BRepModel, dict[int, codec.NetCode], LossyReport]:
    """Code the model's B-spline surface nets and 3-D curve poles within ``tol``.

    Returns
    -------
    decoded : BRepModel
        What the decoder will rebuild (shares unchanged tables with ``m``).
    codes : dict
        ``id(record in decoded) -> NetCode`` for the container.
    report : LossyReport
    """
    codes: dict[int, codec.NetCode] = {}
    surfaces, scodes = _code_table(
        m.surfaces,
        tol,
        _offset_bases(m.surfaces, Kind.OFFSET_SURFACE, _TRIM_S),
        lambda g: codec.SURFACE_METHODS,
        paper,
        codes,
    )
    curves, ccodes = _code_table(
        m.curves3d,
        tol,
        _offset_bases(m.curves3d, Kind.OFFSET_CURVE, _TRIM_C),
        lambda g: codec.CURVE_METHODS,
        paper,
        codes,
    )

    def curve_bound(i: int) -> float:
        if i < 0:
            return 0.0
        c = ccodes.get(id(_resolve(curves, i, _TRIM_C)))
        return c.bound if c else 0.0

    face_bound = np.zeros(len(m.face_surface))
    face_method = []
    for f, row in enumerate(m.face_surface.tolist()):
        b = _resolve(surfaces, row, _TRIM_S)
        c = scodes.get(id(b))
        if c is not None:
            face_bound[f] = c.bound
            face_method.append(c.method.name.lower())
        elif isinstance(b, Derived) and b.kind in (Kind.REVOLUTION, Kind.EXTRUSION):
            # sweeping is an isometry of each curve point: the surface moves as the curve
            face_bound[f] = curve_bound(b.basis)
            face_method.append("swept" if face_bound[f] > 0 else "exact")
        else:
            face_method.append("exact")
    reps = m.edge_reps
    edge_bound = np.zeros(len(m.edge_tol))
    for q in np.flatnonzero(reps[:, 1] == RepKind.CURVE3D).tolist():
        edge_bound[reps[q, 0]] = max(edge_bound[reps[q, 0]], curve_bound(int(reps[q, 2])))
    out = _widen_tolerances(m, face_bound, edge_bound)
    out.surfaces, out.curves3d = surfaces, curves
    npoles = sum(int(np.prod(g.poles.shape[:-1])) for g in surfaces if id(g) in scodes)
    report = LossyReport(
        face_method,
        face_bound,
        edge_bound,
        sum(c.bits for c in scodes.values()),
        npoles,
        sum(c.bits for c in ccodes.values()),
        sum(len(g.poles) for g in curves if id(g) in ccodes),
    )
    return out, codes, report


#: BRepCheck measures an edge's distance to its surfaces with a 5% margin
#: (BRepLib_ValidateEdge); tolerances are widened by the bound times this.
MARGIN = 1.1


def _widen_tolerances(m: BRepModel, face_bound: np.ndarray, edge_bound: np.ndarray) -> BRepModel:
    """A copy of ``m`` whose edge and vertex tolerances cover the coding errors.

    An edge's 3-D curve moved by its curve's bound and each of its surfaces by
    their faces' bounds, so its curve-to-surface distances grow by at most their
    sum; a vertex's distance to the ends of its curves and pcurves by at most
    the largest of them.
    """
    tidx = m.type_index()
    faces = np.flatnonzero(m.shape_type == ShapeType.FACE)
    edges = np.flatnonzero(m.shape_type == ShapeType.EDGE)
    extra_e = np.zeros(len(m.edge_tol))
    extra_v = np.zeros(len(m.vertex_tol))
    for f, s in enumerate(faces.tolist()):
        b = face_bound[f]
        if b <= 0:
            continue
        for e in below(m, s, ShapeType.EDGE):
            extra_e[tidx[e]] = max(extra_e[tidx[e]], b)
    for k, s in enumerate(edges.tolist()):
        reach = max(extra_e[k], edge_bound[k])
        extra_e[k] += edge_bound[k]
        if reach > 0:
            for v in below(m, s, ShapeType.VERTEX):
                extra_v[tidx[v]] = max(extra_v[tidx[v]], reach)
    out: Any = replace(m)
    out.edge_tol = m.edge_tol + MARGIN * extra_e
    out.vertex_tol = m.vertex_tol + MARGIN * extra_v
    return out
