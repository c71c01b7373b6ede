"""Tolerance mode on a whole model: code every B-spline surface net, keep the B-rep valid.

:func:`encode_model` runs the per-net search of :mod:`nurbscomp.codec` on each
distinct B-spline or Bezier surface, and returns the model the decoder will
rebuild: the same tables with the *decoded* nets, and with edge and vertex
tolerances widened by the coding error of the faces around them (the curves
and pcurves are still exact, so an edge's distance to its moved surface grows
by at most that face's bound).

What this version does not code yet (it stays exact): curves, pcurves,
vertices, analytic surfaces, and B-spline surfaces under an offset surface
(an offset of a moved surface can move by more than the poles did).
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from . import codec
from .model import BRepModel, BSplineSurface, Derived, Geometry, Kind, ShapeType
from .serialize import net_abscissae


@dataclass
class LossyReport:
    """What the search chose.

    Attributes
    ----------
    face_method : list of str
        Per face (model order): ``"spatial"``, ``"boundary"`` (the paper's "no
        difference data"), ``"ddmap"``, or ``"exact"`` (not a coded net).
    face_bound : ndarray, shape (F,)
        Certified bound per face (0 for exact faces).
    net_bits : float
        Estimated bits of all coded nets (before the entropy stage).
    poles : int
        Poles of the coded nets.
    """

    face_method: list[str]
    face_bound: np.ndarray
    net_bits: float
    poles: int

    def method_counts(self) -> dict[str, int]:
        return dict(collections.Counter(self.face_method))


def _basis(surfaces: list[Geometry], i: int) -> Geometry:
    g = surfaces[i]
    while isinstance(g, Derived) and g.kind == Kind.TRIMMED_SURFACE:
        g = surfaces[g.basis]
    return g


def _offset_bases(surfaces: list[Geometry]) -> set[int]:
    """Ids of records under an offset surface: they must stay exact."""
    out: set[int] = set()
    for g in surfaces:
        if isinstance(g, Derived) and g.kind == Kind.OFFSET_SURFACE:
            b = surfaces[g.basis]
            while True:
                out.add(id(b))
                if isinstance(b, Derived) and b.kind in (Kind.TRIMMED_SURFACE, Kind.OFFSET_SURFACE):
                    b = surfaces[b.basis]
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


def encode_model(
    m: BRepModel, tol: float, paper: bool = False
) -> tuple[BRepModel, dict[int, codec.NetCode], LossyReport]:
    """Code the model's B-spline nets within ``tol``.

    Returns
    -------
    decoded : BRepModel
        What the decoder will rebuild (shares unchanged tables with ``m``).
    codes : dict
        ``id(record in decoded.surfaces) -> NetCode`` for the container.
    report : LossyReport
    """
    keep = _offset_bases(m.surfaces)
    new: dict[int, Geometry] = {}
    codes: dict[int, codec.NetCode] = {}
    bound_of: dict[int, float] = {}
    method_of: dict[int, str] = {}
    origin = None
    bits, poles = 0.0, 0
    for g in m.surfaces:
        if id(g) in new or not isinstance(g, BSplineSurface) or id(g) in keep:
            continue
        s, t = net_abscissae(g)
        periodic = g.uperiodic or g.vperiodic
        methods = (codec.Method.SPATIAL,) if periodic else tuple(codec.Method)
        code = codec.encode_net(g.poles, s, t, tol, methods, paper=paper, origin=origin)
        net, _ = codec.decode_net(code, g.poles.shape, s, t, tol, origin)
        origin = net[0, 0]
        rec = replace(g, poles=net)
        new[id(g)] = rec
        codes[id(rec)] = code
        bound_of[id(rec)] = code.bound
        method_of[id(rec)] = code.method.name.lower()
        bits += code.bits
        poles += net.shape[0] * net.shape[1]
    surfaces = [new.get(id(g), g) for g in m.surfaces]
    # derived surfaces keep their basis index; trimmed ones inherit the bound
    face_bound = np.zeros(len(m.face_surface))
    face_method = []
    for f, row in enumerate(m.face_surface.tolist()):
        b = _basis(surfaces, row)
        face_bound[f] = bound_of.get(id(b), 0.0)
        face_method.append(method_of.get(id(b), "exact"))
    out = _widen_tolerances(m, face_bound)
    out.surfaces = surfaces
    return out, codes, LossyReport(face_method, face_bound, bits, poles)


#: BRepCheck measures an edge's distance to its surfaces with a 5% margin
#: (BRepLib_ValidateEdge); tolerances are widened by the bound times this.
MARGIN = 1.1


def _widen_tolerances(m: BRepModel, face_bound: np.ndarray) -> BRepModel:
    """A copy of ``m`` whose edge and vertex tolerances cover the faces' coding errors."""
    tidx = m.type_index()
    faces = np.flatnonzero(m.shape_type == ShapeType.FACE)
    extra_e = np.zeros(len(m.edge_tol))
    extra_v = np.zeros(len(m.vertex_tol))
    for f, s in enumerate(faces.tolist()):
        b = face_bound[f]
        if b <= 0:
            continue
        for e in below(m, s, ShapeType.EDGE):
            extra_e[tidx[e]] = max(extra_e[tidx[e]], b)
            for v in below(m, e, ShapeType.VERTEX):
                extra_v[tidx[v]] = max(extra_v[tidx[v]], b)
    out: Any = replace(m)
    out.edge_tol = m.edge_tol + MARGIN * extra_e
    out.vertex_tol = m.vertex_tol + MARGIN * extra_v
    return out
