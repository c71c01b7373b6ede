"""SHAP from format 2.0: the topology coded by prediction (docs/format.md §2.5.1).

Every table of the shapes must come back equal, on golden and corpus models
and on generated shapes with the topologies the walk predicts worst (located
instances, several solids, open shells, holes, seams, non-manifold edges,
free shapes, INTERNAL/EXTERNAL orientations); a model the walk does not number
falls back to the arrays; hostile bytes fail with a FormatError.
"""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest

from nurbscomp import container, occ, serialize, topocode
from nurbscomp.errors import FormatError, LimitError
from nurbscomp.model import BRepModel

from . import fuzz
from .conftest import CORPUS

GOLDEN = Path(__file__).parent / "golden"
TABLES = ("shape_type", "shape_flags", "child_start", "child_shape", "child_orient", "child_loc")


def _round_trip(m: BRepModel, mode: int | None = topocode.MODE_IMPLIED) -> bytes:
    raw = serialize._write_shapes(m)
    if mode is not None:
        assert raw[0] == mode
    back = BRepModel()
    serialize._read_shapes(raw, back, container.REVISION, None)
    for name in TABLES:
        a, b = getattr(m, name), getattr(back, name)
        assert np.array_equal(a, b), name
        assert len(a) == len(b)
    assert (back.root_shape, back.root_orient, back.root_loc) == (
        m.root_shape,
        m.root_orient,
        m.root_loc,
    )
    return raw


def _shapes_of(shape: object) -> BRepModel:
    m, _ = occ.shape_to_model(shape)
    return m


GOLDENS = sorted(p.name for p in GOLDEN.glob("*.nzc"))


@pytest.mark.parametrize("name", GOLDENS)
def test_golden_models_round_trip(name: str) -> None:
    m, _ = fuzz.decoded((GOLDEN / name).read_bytes())
    _round_trip(m)


def test_coded_is_smaller_than_the_arrays() -> None:
    m, _ = fuzz.decoded((GOLDEN / "bracket.lossless.nzc").read_bytes())
    coded = serialize._write_shapes(m)
    assert coded[0] == topocode.MODE_IMPLIED
    assert len(coded) < len(serialize._write_shape_arrays(m)) / 2


@pytest.mark.corpus
@pytest.mark.slow
@pytest.mark.parametrize(
    "name", ["occt__bearing.iges", "axom_data__boxed_sphere.step", "trimesh__featuretype.STEP"]
)
def test_corpus_models_round_trip(name: str) -> None:
    path = CORPUS / name
    if not path.exists():
        pytest.skip("no corpus")
    shape = occ.read_cad(path).shape
    _round_trip(_shapes_of(shape))


def _cq():  # type: ignore[no-untyped-def]
    return pytest.importorskip("cadquery")


def test_assembly_with_instances() -> None:
    cq = _cq()
    box = cq.Workplane().box(2, 3, 4).val()
    cyl = cq.Workplane().cylinder(5, 1).val()
    assy = cq.Assembly(name="top")
    for k in range(3):
        assy.add(box, name=f"b{k}", loc=cq.Location((10 * k, 0, 0)))
    assy.add(cyl, name="c", loc=cq.Location((0, 10, 0), (1, 0, 0), 30))
    m = _shapes_of(assy.toCompound().wrapped)
    assert (m.child_loc > 0).sum() >= 3
    _round_trip(m)


def test_compound_of_solids_holes_seams_and_free_shapes() -> None:
    cq = _cq()
    plate = cq.Workplane().box(10, 10, 1).faces(">Z").workplane().hole(3).val()
    sphere = cq.Workplane().sphere(2).translate((20, 0, 0)).val()
    torus = cq.Solid.makeTorus(5, 1).translate((0, 20, 0))
    cone = cq.Solid.makeCone(2, 0, 3).translate((0, -20, 0))
    edge = cq.Edge.makeLine(cq.Vector(0, 0, 0), cq.Vector(1, 1, 1))
    wire = cq.Wire.makeCircle(2, cq.Vector(5, 5, 5), cq.Vector(0, 0, 1))
    vertex = cq.Vertex.makeVertex(3, 3, 3)
    face = cq.Face.makeFromWires(cq.Wire.makePolygon([(0, 0, 9), (1, 0, 9), (0, 1, 9)], close=True))
    comp = cq.Compound.makeCompound([plate, sphere, torus, cone, edge, wire, vertex, face])
    _round_trip(_shapes_of(comp.wrapped))


def test_open_shell_and_shared_faces() -> None:
    cq = _cq()
    box = cq.Workplane().box(1, 2, 3).val()
    faces = box.Faces()[:4]
    shell = cq.Shell.makeShell(faces)
    # the same faces once more in a second shell: faces shared by two shells
    comp = cq.Compound.makeCompound([shell, cq.Shell.makeShell(faces[:2])])
    _round_trip(_shapes_of(comp.wrapped))


def test_non_manifold_edges() -> None:
    cq = _cq()
    from OCP.BOPAlgo import BOPAlgo_MakerVolume
    from OCP.TopTools import TopTools_ListOfShape

    a = cq.Workplane().box(2, 2, 2).val()
    b = cq.Workplane().box(2, 2, 2).translate((2, 0, 0)).val()
    c = cq.Workplane().box(2, 2, 2).translate((0, 2, 0)).val()
    args = TopTools_ListOfShape()
    for s in (a, b, c):
        args.Append(s.wrapped)
    mv = BOPAlgo_MakerVolume()
    mv.SetArguments(args)
    mv.Perform()
    m = _shapes_of(mv.Shape())
    wires = np.flatnonzero(m.shape_type == 5)
    used = np.concatenate([m.child_shape[m.child_start[w] : m.child_start[w + 1]] for w in wires])
    assert np.bincount(used).max() >= 3  # an edge of three or more faces
    _round_trip(m)


def test_internal_and_external_orientations() -> None:
    m, _ = fuzz.decoded((GOLDEN / "bracket.lossless.nzc").read_bytes())
    rng = np.random.default_rng(7)
    m.child_orient = rng.integers(0, 4, len(m.child_orient)).astype(np.uint8)
    m.root_orient = 3
    _round_trip(m)


def _walk_round_trip(m: BRepModel) -> bool:
    """The walk's streams alone, mode 1's and mode 2's (with the model's
    properties), decode to ``m``'s tables (False: the walk does not write
    ``m``)."""
    if not topocode._model_fits(m):
        return False
    for implied in (None, topocode.properties(m)):
        coded = topocode.encode(m, implied)
        if coded is None:
            return False
        t = topocode.decode(coded, len(m.shape_type), len(m.child_shape), None, implied)
        assert t["types"] == m.shape_type.tolist()
        assert t["flags"] == m.shape_flags.tolist()
        assert t["start"] == m.child_start.tolist()
        assert t["shape"] == m.child_shape.tolist()
        assert t["orient"] == m.child_orient.tolist()
        assert t["loc"] == m.child_loc.tolist()
        assert (t["root_orient"], t["root_loc"]) == (m.root_orient, m.root_loc)
    return True


@pytest.mark.slow
def test_random_trees_round_trip() -> None:
    """Random DAGs numbered in depth-first post-order from the root: whatever
    mode the writer picks, the tables come back; most go through the walk
    (a wire's child that an earlier sibling's walk numbers does not)."""
    rng = random.Random(5)
    walked = 0
    for _ in range(60):
        m = _random_model(rng)
        _round_trip(m, None)
        walked += _walk_round_trip(m)
    assert walked >= 30


def test_wire_reuses_its_new_edge_far_back() -> None:
    """A wire naming again a new edge of its own more than PENDING edges
    back (a seam-like loop, as in bug32596) goes through the walk."""
    m = BRepModel()
    n = topocode.PENDING + 3
    # vertices 3k, edges 3k+2 over vertices 3k and 3k+1... numbered post-order
    types: list[int] = []
    kids: list[list[int]] = []
    for _ in range(n):
        types += [7, 7, 6]
        b = len(types) - 3
        kids += [[], [], [b, b + 1]]
    edges = [3 * k + 2 for k in range(n)]
    types.append(5)
    kids.append(edges + [edges[0]])
    m.shape_type = np.array(types, np.uint8)
    m.shape_flags = np.zeros(len(types), np.uint8)
    m.child_start = np.concatenate([[0], np.cumsum([len(k) for k in kids])]).astype(np.int64)
    m.child_shape = np.array([c for k in kids for c in k], np.int64)
    orient = [[0, 1] if len(k) == 2 else [0] * (len(k) - 1) + [1] for k in kids if k]
    m.child_orient = np.array([o for k in orient for o in k], np.uint8)
    m.child_loc = np.zeros(len(m.child_shape), np.int64)
    m.root_shape, m.root_orient, m.root_loc = len(types) - 1, 0, 0
    assert _walk_round_trip(m)


@pytest.mark.slow
def test_tiny_model_written_the_smaller_way() -> None:
    """Under 512 coded bytes the writer keeps the arrays when they compress
    smaller: no tiny model is larger than in the 1.x layout."""
    import lzma

    rng = random.Random(8)
    for _ in range(20):
        m = _random_model(rng)
        raw = serialize._write_shapes(m)
        arrays = bytes([topocode.MODE_ARRAYS]) + serialize._write_shape_arrays(m)
        x = lzma.compress(raw, preset=9 | lzma.PRESET_EXTREME)
        assert len(x) <= len(lzma.compress(arrays, preset=9 | lzma.PRESET_EXTREME))


def _random_model(rng: random.Random) -> BRepModel:
    types: list[int] = []
    kids: list[list[tuple[int, int, int]]] = []

    def make(t: int, depth: int) -> int:
        own = []
        for _ in range(rng.randrange(0, 5) if t < 7 and depth < 6 else 0):
            if types and rng.random() < 0.4:
                c = rng.randrange(len(types))
            else:
                c = make(min(7, t + rng.choice((1, 1, 1, 2))), depth + 1)
            own.append((c, rng.randrange(4), rng.choice((0, 0, 0, 1, 2))))
        types.append(t)
        kids.append(own)
        return len(types) - 1

    root = make(rng.randrange(8), 0)
    m = BRepModel()
    m.shape_type = np.array(types, np.uint8)
    m.shape_flags = np.array([rng.randrange(256) for _ in types], np.uint8)
    m.child_start = np.concatenate([[0], np.cumsum([len(k) for k in kids])]).astype(np.int64)
    m.child_shape = np.array([c for k in kids for c, _, _ in k], np.int64)
    m.child_orient = np.array([o for k in kids for _, o, _ in k], np.uint8)
    m.child_loc = np.array([loc for k in kids for _, _, loc in k], np.int64)
    m.root_shape, m.root_orient, m.root_loc = root, rng.randrange(4), rng.randrange(3)
    return m


def test_unreached_shapes_fall_back_to_the_arrays() -> None:
    m, _ = fuzz.decoded((GOLDEN / "bracket.lossless.nzc").read_bytes())
    # a vertex nothing refers to, numbered before the root
    n = len(m.shape_type)
    m.shape_type = np.insert(m.shape_type, n - 1, 7)
    m.shape_flags = np.insert(m.shape_flags, n - 1, 0)
    m.child_start = np.insert(m.child_start, n - 1, m.child_start[n - 1])
    m.root_shape = n
    m.child_shape = np.where(m.child_shape >= n - 1, m.child_shape + 1, m.child_shape)
    _round_trip(m, topocode.MODE_ARRAYS)
    # out of depth-first order: two children of the root swapped
    m2, _ = fuzz.decoded((GOLDEN / "bracket.lossless.nzc").read_bytes())
    r = m2.root_shape
    a, b = int(m2.child_start[r]), int(m2.child_start[r + 1])
    if b - a >= 2:
        m2.child_shape[[a, a + 1]] = m2.child_shape[[a + 1, a]]
        _round_trip(m2, topocode.MODE_ARRAYS)


def test_old_revisions_read_the_arrays() -> None:
    m, _ = fuzz.decoded((GOLDEN / "bracket.lossless.nzc").read_bytes())
    raw = serialize._write_shape_arrays(m)
    for rev in range(3):
        back = BRepModel()
        serialize._read_shapes(raw, back, rev, None)
        assert np.array_equal(back.child_shape, m.child_shape)
    with pytest.raises(FormatError):
        serialize._read_shapes(raw, BRepModel(), 3, None)


@pytest.mark.slow
def test_hostile_bytes_fail_with_format_errors() -> None:
    m, _ = fuzz.decoded((GOLDEN / "bracket.lossless.nzc").read_bytes())
    good = serialize._write_shapes(m)
    rng = random.Random(11)
    cases = [b"", b"\x07", good[:5], good[:-1], good + b"\0", bytes([1]) + good[1:9]]
    for _ in range(300):
        b = bytearray(good)
        for _ in range(rng.randrange(1, 4)):
            k = rng.randrange(len(b))
            b[k] = rng.randrange(256)
        cases.append(bytes(b))
    ok = 0
    for data in cases:
        try:
            serialize._read_shapes(data, BRepModel(), container.REVISION, None)
            ok += 1
        except FormatError:
            pass
    assert ok < len(cases)


def _bracket() -> BRepModel:
    m, _ = fuzz.decoded((GOLDEN / "bracket.lossless.nzc").read_bytes())
    return m


def _edges_kids(m: BRepModel) -> np.ndarray:
    """Where the references of the edges are in the child arrays."""
    kids = np.diff(m.child_start)
    return np.flatnonzero(np.repeat(m.shape_type, kids) == 6)


def test_mode_2_names_the_properties_a_model_has() -> None:
    """Format 2.19: each property mode 2 leaves out is named only where the
    model has it, and the tables come back whichever are named."""
    m = _bracket()
    every = topocode.IMPLIED_ALL
    assert topocode.properties(m) == every
    assert _round_trip(m)[1] == every
    # an edge whose vertices come REVERSED, then FORWARD
    m1 = _bracket()
    at = _edges_kids(m1)[:2]
    m1.child_orient[at] = m1.child_orient[at[::-1]]
    assert topocode.properties(m1) == every & ~topocode.ENDS_FR
    assert _round_trip(m1)[1] == every & ~topocode.ENDS_FR
    # a face used with a location in its shell
    m2 = _bracket()
    kids = np.diff(m2.child_start)
    faces = np.flatnonzero(np.repeat(m2.shape_type, kids) == 3)
    m2.child_loc[faces[0]] = 1
    assert topocode.properties(m2) == every & ~topocode.UNLOCATED
    assert _round_trip(m2)[1] == every & ~topocode.UNLOCATED
    # an edge with one vertex (a third reference would renumber the model):
    # neither TWO_ENDS nor ENDS_FR, and the flags still come back
    m3 = _bracket()
    e = int(np.flatnonzero(m3.shape_type == 6)[0])
    k = int(m3.child_start[e]) + 1
    m3.child_shape = np.delete(m3.child_shape, k)
    m3.child_orient = np.delete(m3.child_orient, k)
    m3.child_loc = np.delete(m3.child_loc, k)
    m3.child_start[e + 1 :] -= 1
    if topocode._model_fits(m3):
        props = topocode.properties(m3)
        assert not props & (topocode.TWO_ENDS | topocode.ENDS_FR)
        assert _round_trip(m3)[1] == props
    # a wire holding a vertex, a shell holding a wire: no type implied
    m4 = _random_model(random.Random(3))
    assert _walk_round_trip(m4) or not topocode._model_fits(m4)


def test_mode_2_closed_edges_cost_less() -> None:
    """Mode 2 codes an edge's flags under whether its two ends are one vertex:
    OCCT's own shapes set the closed flag on those (a plate's round holes)."""
    cq = _cq()
    plate = cq.Workplane().box(40, 40, 2).faces(">Z").workplane()
    plate = plate.rarray(8, 8, 4, 4).hole(3).val()
    m = _shapes_of(plate.wrapped)
    closed = [
        int(m.shape_flags[e])
        for e in np.flatnonzero(m.shape_type == 6)
        if m.child_shape[m.child_start[e]] == m.child_shape[m.child_start[e] + 1]
    ]
    assert sum(1 for f in closed if f & 16) >= 16  # the closed bit, on each hole's circle
    one = topocode.encode(m)
    two = topocode.encode(m, topocode.properties(m))
    assert one is not None and two is not None
    assert len(two) < len(one)
    _round_trip(m)


def test_mode_2_is_refused_before_its_revision() -> None:
    """A 2.18 reader takes mode 1 and the arrays, not mode 2; a 2.19 reader
    still takes mode 1 (every earlier container decodes)."""
    m = _bracket()
    two = serialize._write_shapes(m)
    assert two[0] == topocode.MODE_IMPLIED
    with pytest.raises(FormatError):
        serialize._read_shapes(two, BRepModel(), container.SHAP_IMPLIED - 1, None)
    coded = topocode.encode(m)
    assert coded is not None
    one = topocode.HEAD.pack(topocode.MODE_WALK, len(m.shape_type), len(m.child_shape)) + coded
    for rev in (container.SHAP_IMPLIED - 1, container.REVISION):
        back = BRepModel()
        serialize._read_shapes(one, back, rev, None)
        for name in TABLES:
            assert np.array_equal(getattr(back, name), getattr(m, name)), name


@pytest.mark.parametrize("props", [32, 64, 128, topocode.ENDS_FR, topocode.ENDS_FR | 1])
def test_mode_2_unknown_properties_are_refused(props: int) -> None:
    good = serialize._write_shapes(_bracket())
    bad = good[:1] + bytes([props]) + good[2:]
    with pytest.raises(FormatError, match="properties"):
        serialize._read_shapes(bad, BRepModel(), container.REVISION, None)


def test_declared_counts_are_bounded() -> None:
    head = topocode.HEAD.pack(topocode.MODE_WALK, 2_000_000, 0)
    with pytest.raises(LimitError):
        from nurbscomp import budget

        serialize._read_shapes(head + bytes(5), BRepModel(), 3, budget.DEFAULT)
    # a huge count with few bytes ends in an error, not a long loop
    head = topocode.HEAD.pack(topocode.MODE_WALK, 900_000, 90_000)
    with pytest.raises(FormatError):
        serialize._read_shapes(head + bytes(64), BRepModel(), 3, None)
    # the same of mode 2 (format 2.19)
    rev = container.SHAP_IMPLIED
    head2 = topocode.HEAD2.pack(topocode.MODE_IMPLIED, topocode.IMPLIED_ALL, 2_000_000, 0)
    with pytest.raises(LimitError):
        from nurbscomp import budget

        serialize._read_shapes(head2 + bytes(5), BRepModel(), rev, budget.DEFAULT)
    head2 = topocode.HEAD2.pack(topocode.MODE_IMPLIED, topocode.IMPLIED_ALL, 900_000, 90_000)
    with pytest.raises(FormatError):
        serialize._read_shapes(head2 + bytes(64), BRepModel(), rev, None)


@pytest.mark.parametrize("which", ["plane", "box", "cylinder"])
def test_a_small_container_keeps_the_smaller_walk_mode(which: str) -> None:
    """A container of at most 2 KiB is packed with SHAP in mode 2 and in mode
    1, and the smaller kept (``stages.compress.MODE_1_SMALL``): the
    dictionary coders hold earlier writers' mode-1 streams of common small
    models. The other mode's container is never smaller."""
    cq = _cq()
    import nurbscomp
    from nurbscomp.serialize import sections as S

    shape = {
        "plane": lambda: cq.Face.makePlane(10, 10),
        "box": lambda: cq.Workplane().box(3, 4, 5).val(),
        "cylinder": lambda: cq.Workplane().cylinder(5, 2).val(),
    }[which]()
    data = nurbscomp.compress(shape, tol=0.1)
    c = container.unpack(data)
    m, _, _ = S.read_sections(c.get, c.revision, None)
    written = c.get("SHAP")
    assert written[0] in (topocode.MODE_WALK, topocode.MODE_IMPLIED)
    one = serialize.walk_section(m)
    assert one is not None
    two = serialize._write_shapes(m)
    other = one if written[0] == topocode.MODE_IMPLIED else two
    alt = [(s.tag, other if s.tag == "SHAP" else s.raw) for s in c.sections]
    assert len(data) <= len(container.pack(alt, c.flags))
    back = BRepModel()
    serialize._read_shapes(other, back, container.REVISION, None)
    for name in TABLES:
        assert np.array_equal(getattr(back, name), getattr(m, name)), name


def test_brep_exact_containers_of_large_models_hold_the_arrays(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A B-rep-exact container of a model of ``ARRAYS_REFS`` references or
    more holds SHAP as arrays (mode 0), which decode without the walk's
    loop, and builds the shape the walk's container builds; under the
    threshold, and in tolerance mode, the walk stays."""
    from nurbscomp import pipeline
    from nurbscomp.serialize import topology
    from nurbscomp.stages import decompress

    from .conftest import SAMPLES, brep_bytes

    src = SAMPLES / "assembly.step"

    def made(name: str, **kw: object) -> tuple[int, bytes]:
        out = tmp_path / name
        pipeline.compress_file(src, out, **kw)  # type: ignore[arg-type]
        c = container.unpack(out.read_bytes())
        return c.get("SHAP")[0], brep_bytes(decompress.decode_file(out)[0])

    walk, shape = made("walk.nzc", tol=None, lossless=True)
    refs = len(_shapes_of(occ.read_cad(src).shape).child_shape)
    assert refs < topology.ARRAYS_REFS and walk == topocode.MODE_IMPLIED
    monkeypatch.setattr(topology, "ARRAYS_REFS", refs)
    arrays, same = made("arrays.nzc", tol=None, lossless=True)
    assert arrays == topocode.MODE_ARRAYS and same == shape
    assert made("tol.nzc", tol=0.1)[0] == topocode.MODE_IMPLIED
