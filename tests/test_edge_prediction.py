"""Format 2.11 EDGE by prediction (issue 28 item 2, docs/format.md §2.7,
"Predicted representations"): representation kinds predicted from the faces
around each edge, range kinds and surface picks stored against predictions,
no end points for computed pcurves."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from nurbscomp import container
from nurbscomp.errors import LimitError, SectionError
from nurbscomp.model import EC, RepKind
from nurbscomp.serialize import edges as E
from nurbscomp.streams import BlockReader, BlockWriter

from . import fuzz

GOLDEN = Path(__file__).resolve().parent / "golden"
NAMES = ("bracket.v2_11.tol0.01.nzc", "teapot.v2_11.faces.tol0.1.nzc", "loft.v2_10.tol0.01.nzc")


def _model(name: str):  # type: ignore[no-untyped-def]
    m, _ = fuzz.decoded((GOLDEN / name).read_bytes())
    return m


def _how(m) -> np.ndarray:  # type: ignore[no-untyped-def]
    from nurbscomp.rules.ranges import range_kinds

    return range_kinds(m)


def _round_trip(m, revision: int = container.REVISION):  # type: ignore[no-untyped-def]
    """``m``'s EDGE written at ``revision`` and read back into a copy of ``m``
    (the other tables kept), with the bytes."""
    from copy import copy

    raw = E._write_edges(m, _how(m), revision)
    back = copy(m)
    how, picks = E._read_edges(raw, back, revision)
    assert picks is not None
    E._resolve_picks(back, picks, np.inf)
    return back, raw, how


def _odd(raw: bytes) -> np.ndarray:
    r = BlockReader(raw, "EDGE")
    n = len(E._read_tolerances(r, None, "EDGE"))
    r.ints(n)
    r.ints(3)  # the settings
    return r.deltas()


def _same_edges(a, b) -> None:  # type: ignore[no-untyped-def]
    np.testing.assert_array_equal(a.edge_reps, b.edge_reps)
    np.testing.assert_array_equal(a.edge_rep_cont, b.edge_rep_cont)
    assert a.edge_rep_uv.view(np.int64).tolist() == b.edge_rep_uv.view(np.int64).tolist()


@pytest.mark.parametrize("name", NAMES)
def test_predictions_hold_on_the_golden_models(name: str) -> None:
    """Every edge of these models has its predicted kinds, and every range
    kind and surface pick its prediction: the arrays are all zeros."""
    m = _model(name)
    back, raw, _ = _round_trip(m)
    _same_edges(m, back)
    assert len(_odd(raw)) == 0
    uses = E.edge_uses(m)
    kind = m.edge_reps[:, EC.KIND]
    pred = E.predicted_ranges(m, kind, m.edge_reps[:, EC.CURVE])
    ranged = kind != RepKind.ON_TWO_SURFACES
    assert (pred[ranged] == _how(m)[ranged]).mean() > 0.9
    cands = E.edge_candidates(m, uses=uses)
    p1, _ = E.predicted_picks(m, E.pcurve_faces(m, uses), cands)
    on = kind != RepKind.CURVE3D
    got = E._picks(m.edge_reps[on, EC.SURFACE], m.edge_reps[on, EC.EDGE], cands)
    assert (got == p1).all()


def test_smaller_than_the_2_10_layout() -> None:
    m = _model("bracket.v2_11.tol0.01.nzc")
    _, new, _ = _round_trip(m)
    old = E._write_edges(m, _how(m), container.VERSIONS.index((2, 10)))
    assert len(new) < len(old) * 0.6


def test_an_edge_off_its_prediction_is_stored() -> None:
    """A representation list in another order (a pcurve before the 3-D curve,
    as some IGES files have it) is an odd edge, and comes back as it was."""
    m = _model("bracket.v2_11.tol0.01.nzc")
    reps = m.edge_reps.copy()
    e = int(reps[np.flatnonzero(reps[:, EC.KIND] == RepKind.ON_SURFACE)[0], EC.EDGE])
    rows = np.flatnonzero(reps[:, EC.EDGE] == e)
    order = np.arange(len(reps))
    order[rows] = rows[::-1]
    m.edge_reps, m.edge_rep_range = reps[order], m.edge_rep_range[order]
    m.edge_rep_uv, m.edge_rep_cont = m.edge_rep_uv[order], m.edge_rep_cont[order]
    back, raw, _ = _round_trip(m)
    _same_edges(m, back)
    assert _odd(raw).tolist() == [e]


def test_a_computed_pcurve_with_end_points_keeps_them() -> None:
    """Range kind 3 stores no end points; a pcurve of zeros range whose end
    points are not zeros is written with its range stored instead."""
    m = _model("bracket.v2_11.tol0.01.nzc")
    how = _how(m)
    q = int(np.flatnonzero(how == E.RANGE_ZERO)[0])
    assert m.edge_reps[q, EC.KIND] in (RepKind.ON_SURFACE, RepKind.ON_CLOSED_SURFACE)
    m.edge_rep_uv[q, :4] = [0.5, 0.25, 1.5, 0.25]
    back, _, how_back = _round_trip(m)
    _same_edges(m, back)
    assert how_back[q] == E.RANGE_STORED
    assert (back.edge_rep_range[q] == 0).all()


def _hostile(m, edit) -> bytes:  # type: ignore[no-untyped-def]
    """``m``'s EDGE with its odd-edge arrays replaced by ``edit()``'s three."""
    raw = E._write_edges(m, _how(m), container.REVISION)
    r = BlockReader(raw, "EDGE")
    w = BlockWriter()
    E._write_tolerances(w, E._read_tolerances(r, None, "EDGE"))
    w.ints(r.ints(len(m.edge_tol)))
    w.ints(r.ints(3))
    r.deltas(), r.ints(), r.ints()
    odd, per, kinds = edit()
    w.deltas(odd)
    w.ints(per)
    w.ints(kinds)
    return bytes(w) + raw[len(raw) - r.remaining :]


@pytest.mark.parametrize(
    ("arrays", "match"),
    [
        (([3, 2], [1, 1], [0, 0]), "not increasing"),
        (([10**6], [1], [0]), "not increasing"),
        (([0], [10**6], [0]), "count"),
        (([0], [2], [0, 7]), "unknown representation kind"),
    ],
)
def test_hostile_odd_edges_are_refused(arrays, match: str) -> None:  # type: ignore[no-untyped-def]
    from copy import copy

    m = _model("bracket.v2_11.tol0.01.nzc")
    raw = _hostile(m, lambda: arrays)
    with pytest.raises(SectionError, match=match):
        E._read_edges(raw, copy(m), container.REVISION)


def test_the_faces_walks_are_bounded() -> None:
    from copy import copy

    m = _model("bracket.v2_11.tol0.01.nzc")
    raw = E._write_edges(m, _how(m), container.REVISION)
    with pytest.raises(LimitError):
        E._read_edges(raw, copy(m), container.REVISION, cap=3)


@pytest.mark.parametrize("name", ["loft.v2_10.tol0.01.nzc", "bracket.v2_11.tol0.01.nzc"])
def test_a_seam_is_predicted_on_a_closed_surface(name: str) -> None:
    """The loft's and the bracket's holes' seams: an edge a face references
    twice is predicted as a pcurve on a closed surface (kind 2)."""
    m = _model(name)
    uses = E.edge_uses(m)
    kinds = E.predicted_kinds(uses, E.pcurve_faces(m, uses))
    twice = [e for e, u in enumerate(uses) if any(n >= 2 for _, n in u)]
    assert twice
    for e in twice:
        assert int(RepKind.ON_CLOSED_SURFACE) in kinds[e]
    per = np.bincount(m.edge_reps[:, EC.EDGE], minlength=len(m.edge_tol))
    first = np.concatenate([[0], np.cumsum(per)])
    got = [m.edge_reps[a:b, EC.KIND].tolist() for a, b in zip(first[:-1], first[1:])]
    assert got == kinds


def test_a_modelled_shape_sets_its_own_predictions() -> None:
    """A shape made by OCCT's modelling algorithms (cadquery, not read from a
    file) has pcurves on its planes and regularity records only on its
    tangent edges: the writer's settings say so, and few edges are odd."""
    import cadquery as cq

    from nurbscomp import occ

    shape = cq.Workplane().box(20, 10, 5).edges("|Z").fillet(2).faces(">Z").hole(3).val()
    m, _ = occ.shape_to_model(shape.wrapped)
    uses = E.edge_uses(m)
    assert E.bare_kinds(m, uses) == 0 and E.regular_edges(m, uses) == 0
    raw = E._write_edges(m, _how(m), container.REVISION)
    assert len(_odd(raw)) <= len(m.edge_tol) // 2  # the tangent edges' regularity
    back, _, _ = _round_trip(m)
    _same_edges(m, back)


@pytest.mark.parametrize("settings", [[1, 2, 0], [-1, 1, 0], [1 << 40, 0, 0], [1, 1, 2]])
def test_hostile_settings_are_refused(settings: list[int]) -> None:
    from copy import copy

    m = _model("bracket.v2_11.tol0.01.nzc")
    raw = E._write_edges(m, _how(m), container.REVISION)
    r = BlockReader(raw, "EDGE")
    w = BlockWriter()
    E._write_tolerances(w, E._read_tolerances(r, None, "EDGE"))
    w.ints(r.ints(len(m.edge_tol)))
    r.ints(3)
    w.ints(settings)
    bad = bytes(w) + raw[len(raw) - r.remaining :]
    with pytest.raises(SectionError, match="settings"):
        E._read_edges(bad, copy(m), container.REVISION)


def test_3d_curves_listed_last_are_a_setting() -> None:
    """An edge of a trimmed surface as OCCT's IGES reader builds it lists its
    pcurve first and the 3-D curve after: with every edge so, the writer's
    setting predicts them all."""
    m = _model("bracket.v2_11.tol0.01.nzc")
    reps = m.edge_reps
    order = []
    for e in range(len(m.edge_tol)):
        rows = np.flatnonzero(reps[:, EC.EDGE] == e)
        three = [q for q in rows if reps[q, EC.KIND] == RepKind.CURVE3D]
        pcs = [
            q for q in rows if reps[q, EC.KIND] in (RepKind.ON_SURFACE, RepKind.ON_CLOSED_SURFACE)
        ]
        rest = [q for q in rows if q not in three and q not in pcs]
        order += pcs + three + rest
    m.edge_reps, m.edge_rep_range = reps[order], m.edge_rep_range[order]
    m.edge_rep_uv, m.edge_rep_cont = m.edge_rep_uv[order], m.edge_rep_cont[order]
    assert E.curves_last(m) == 1
    back, raw, _ = _round_trip(m)
    _same_edges(m, back)
    assert len(_odd(raw)) == 0
