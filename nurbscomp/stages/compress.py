"""Compress's stages: read the source (``read_source``, ``shape_source``),
code it (``encode_cad``: tolerance or lossless mode, the validity stage),
check what was coded (``verify_encoded``), and the report
(``compress_report``)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING, Any

from .. import budget, container, product, serialize, units
from .._version import version
from ..encode import canonical, knots, offsets, pcurves, placed
from ..errors import (
    InputError,
    LimitError,
    NoBRepError,
    UnsupportedError,
    VerifyError,
)
from ..lazy import lazy_module
from ..model import (
    BRepModel,
    BSplineCurve,
    BSplineSurface,
    Derived,
    Kind,
    Table,
    differences,
    nonfinite,
    records,
)
from ..writer import model_to_sections
from .common import DEFAULT_TOL_MM, TOL_WARN_FRACTION, faces_by_type, one_blas_thread
from .decompress import build, decode

if TYPE_CHECKING:
    from .. import occ
else:  # OCP takes seconds to import: only what builds or reads shapes pays for it
    occ = lazy_module("nurbscomp.occ")


@dataclasses.dataclass
class Encoded:
    """A model coded into container bytes, with what the report and the check need
    (:func:`encode_cad`)."""

    data: bytes
    model: BRepModel  # the model read from the source
    target: BRepModel  # what the container holds
    cad: Any  # the occ.CadFile read (or made from a shape)
    meta: dict[str, Any]
    lossless: bool
    tol: float | None
    step_safe: bool
    lossy_report: Any  # encode.assembly.LossyReport, tolerance mode only
    pcurves_rebuilt: int
    built: Any  # the shape built from ``target`` (validity stage, or lossless for verify)
    validity: Any  # encode.validity.ValidityReport, tolerance mode only
    warnings: list[str]


def shape_source(shape: Any, unit: str = "MM") -> Any:
    """An ``occ.CadFile`` for an in-memory ``TopoDS_Shape`` (in millimetres):
    source format ``"BREP"``, no product data.

    Raises
    ------
    NoBRepError
        The shape is null or has no faces.
    """
    if shape.IsNull() or occ.counts(shape)["faces"] == 0:
        raise NoBRepError("the shape holds no B-rep faces")
    return occ.CadFile(shape, unit, "BREP")


#: (target, codes, step_pcurves, uncertainty) -> container bytes
Packer = Callable[..., bytes]

#: Where the validity stage's remedies reach at least this share of the
#: faces (coded tighter, or left exact, because OCCT's reader or BRepCheck
#: mended them), the whole part is coded again ``RETRY_FACTOR`` times
#: tighter, and the smaller container kept (:func:`_coded`).
RETRY_SHARE = 0.25
#: A part of at most this many faces is always coded tighter too, and the
#: smaller kept: it codes in a second or so, and one face climbing can cost
#: more than the tighter coding (a lofted block filleted at its base, 12
#: faces: 2,164 bytes at 0.01 mm, 2,271 at 0.1 mm with two faces tightened;
#: 2,164 with the retry), as can the body coder's luck with a few bytes of
#: META (seven of 105 small IGES surface models grew by 2 to 10 bytes from
#: 0.01 to 0.1 mm; none with the retry, for 38 % more time on them).
RETRY_SMALL = 64
#: ... and at most this many B-spline poles (surfaces and 3-D curves): the
#: net search of every coding grows with them, and a part of few faces with
#: large nets codes in seconds, not in one (ec_turbine-A, 53 faces and 6,994
#: poles: 2.2 s a coding, four of them at 0.01 mm, where the first was the
#: smallest; every part of stress seed 8 has at most 2,069).
RETRY_SMALL_POLES = 4096
#: A part of at most this many faces (and ``RETRY_SMALL_POLES``) is coded
#: ``RETRY_FACTOR`` times tighter too, once, and the smaller kept: a plate
#: of 21 countersunk holes (70 faces, no B-spline) came out 1,093 bytes
#: within 0.01 mm and 1,112 within 0.1 mm, its vertices snapped to the
#: coarser grid widening more edge tolerances to more values; 2 of 18
#: generated parts of 37 to 150 faces grew so, none with the retry, for
#: about twice the time on plates (0.6 -> 1.2 s), 1.3 times on the rest.
#: A plate of 96 filleted bosses and a pocket (299 faces, no B-spline) came
#: out 1,945 bytes at 0.01 mm and 1,950 at 0.1 mm, every section the same
#: but META's tolerance (the body coder's luck): with the retry 1,945 at
#: both, its compress 1.5 -> 2.7 s.
RETRY_MEDIUM = 1024
#: A small part's tighter codings go down to this tolerance (mm), whatever
#: ``RETRY_LEVELS`` says: a filleted box as an IGES B-rep came out 700 bytes
#: at 0.01 mm (coded within 0.0001 mm, two levels down) and 689 at 0.001 mm
#: (within 0.00001 mm), the tighter codings' validity rounds costing less.
SMALL_FLOOR = 1e-5
RETRY_FACTOR = 10
#: At most this many tighter codings (a tolerance larger than the part can
#: need every remedy at every level; the warning says so already).
RETRY_LEVELS = 2
#: Where at least this share of the part's B-spline rows are features finer
#: than tol (``nets.feature_limit``: coded to their own limits, not to tol),
#: the part is coded ``RETRY_FACTOR`` times tighter too, and the smaller
#: container kept: tol then buys little but where the vertices and the STEP
#: reader's mends land, and those land where they will (bearing.iges, a
#: part 0.1 mm across, 99 % such rows at 0.01 mm: 10,056 bytes within
#: 0.01 mm, 9,810 within 0.001 mm).  Once only: the tighter coding does not
#: look for a tighter one still for this reason (bearing at 0.1 mm would be
#: coded three times).
FINE_SHARE = 0.5


def small_part(m: BRepModel) -> bool:
    """Whether ``m`` is a small part, coded tighter down to :data:`SMALL_FLOOR`
    (:data:`RETRY_SMALL` faces, :data:`RETRY_SMALL_POLES` B-spline poles)."""
    return _small(len(m.face_surface), _spline_poles(m), RETRY_SMALL)


def _small(faces: int, poles: int, most: int) -> bool:
    """Whether a part of ``faces`` faces and ``poles`` B-spline poles has at
    most ``most`` faces (:data:`RETRY_SMALL`, or :data:`RETRY_MEDIUM` for a
    part coded within tol/10 once) and :data:`RETRY_SMALL_POLES` poles."""
    return 0 < faces <= most and poles <= RETRY_SMALL_POLES


def _spline_poles(m: BRepModel) -> int:
    """The poles of ``m``'s B-spline surfaces and 3-D curves."""
    rows = (g for g in (*m.surfaces, *m.curves3d) if isinstance(g, (BSplineSurface, BSplineCurve)))
    return sum(g.poles.size // g.poles.shape[-1] for g in rows)


def fine_share(m: BRepModel, tol: float) -> float:
    """The share of ``m``'s B-spline surfaces and curves (rows) that are
    features finer than ``tol`` (:data:`FINE_SHARE`); 0 where it has none."""
    from ..encode import nets

    rows = [g for g in (*m.surfaces, *m.curves3d) if isinstance(g, (BSplineSurface, BSplineCurve))]
    if not rows:
        return 0.0
    return sum(nets.feature_limit(g.poles, tol) < tol for g in rows) / len(rows)


def _offset_bases_coded(m: BRepModel, codes: dict[Any, Any]) -> bool:
    """Whether ``codes`` code the basis of an offset surface of ``m``."""
    recs = records(m.surfaces, Table.SURFACE)
    return any(recs[r] in codes for r in offsets.offsets_by_basis(m.surfaces))


@dataclasses.dataclass
class _Coded:
    tol: float  # what the target is coded within
    target: Any  # encode.validity.Target
    data: bytes
    climbed: int  # faces the validity stage's remedies reached


def _coded(
    m: BRepModel,
    cad: Any,
    tol: float,
    step_safe: bool,
    packer: Callable[[float], Packer],
    level: int = 0,
    ceiling: int | None = None,
    offsets_coded: bool = True,
) -> _Coded | None:
    """The validity stage's target within ``tol`` and its container.

    Where it codes the basis of an offset surface (``encode.offsets``), the
    part is coded again with those bases exact (``offsets_coded`` False, the
    first container's size its ceiling) and the smaller kept: a coded basis
    the offset face's faults then send up the validity ladder can cost more
    than the basis did (a revolved body shelled, as an IGES faces model:
    2,249 bytes with the basis exact, 2,585 coded, at 0.1 mm).

    Where its remedies reach ``RETRY_SHARE`` of the faces or more, what they
    cost can be more than coding the whole part tighter costs: a closed
    net that OCCT's reader mends at 0.1 mm, coded tighter and then exact,
    took 1,308 bytes where the part coded within 0.01 mm took 535.  The part
    is then coded within ``tol / RETRY_FACTOR`` too (by this same rule, at
    most ``RETRY_LEVELS`` times), and the smaller container kept, so that a
    larger tolerance does not give a larger file there (issue 28).  So is a
    small part always (:func:`small_part`, down to ``SMALL_FLOOR``), and a
    part of at most ``RETRY_MEDIUM`` faces once.

    A tighter coding is given the size in hand as its ``ceiling``: it stops
    (None) at the first round whose candidate packs to that size or more
    (``validity.Costlier``), as every later round only adds to it (bearing.iges
    at 0.1 mm: one round of the 0.01 mm coding instead of six, 19 → 12 s).
    One that stops so at its last resort (every record exact:
    ``Costlier.fell_back``), where no coded candidate passed, is followed by
    one tighter still (within the same ``RETRY_LEVELS``), and so is any that
    stops so on a small part (:func:`small_part`)."""
    from ..encode import validity

    pack = packer(tol)
    tighter = tol / RETRY_FACTOR
    faces = len(m.face_surface)
    poles = _spline_poles(m)
    small = _small(faces, poles, RETRY_SMALL)
    # room for a tighter coding: a small part's goes down to SMALL_FLOOR
    # whatever the level, so that what a tolerance tries holds what every
    # smaller one down to the floor tries, and no file grows with it
    deep = small and tighter >= SMALL_FLOOR * (1 - 1e-9)
    room = tighter >= units.TOL_RANGE_MM[0] and (level < RETRY_LEVELS or deep)

    def deepest() -> _Coded | None:
        # a tighter coding asked for that fell back to every record exact:
        # one tighter still may pass where it did not (a twisted loft with
        # filleted ends as an IGES B-rep: 30,208 bytes at 0.1 mm, every record
        # exact, where its coding within 0.001 mm passes in 4,639)
        if not (level and room):
            return None
        return _coded(m, cad, tighter, step_safe, packer, level + 1, ceiling, offsets_coded)

    # a small part's tighter coding cut short by the size in hand goes one
    # tighter still too: a chamfered box as an IGES B-rep came out 239 bytes
    # within 0.01 mm, 229 within 0.001 and 237 within 0.1, where the coding
    # within 0.01 stopped the 0.1 mm one from reaching 0.001's
    try:
        t = validity.lossy_target(
            m, cad.shape, tol, step_safe, pack, cad.pcurves, ceiling, offsets_coded
        )
    except validity.Costlier as e:
        return deepest() if e.fell_back or small else None
    vr = t.validity
    # packed while the STEP check of its last round ran, if it had one
    data = (
        t.early if t.early is not None else pack(t.model, t.codes, vr.step_pcurves, vr.uncertainty)
    )
    if ceiling is not None and len(data) >= ceiling:
        return deepest() if vr.fallback == "exact" or small else None
    # faces left exact for a fault are counted in ``tightened`` too where a
    # rung took them there: the larger count is a floor on the faces reached
    climbed = max(vr.tightened, sum(n for why, n in vr.exact_faces.items() if why != "precision"))
    out = _Coded(tol, t, data, climbed)
    if (
        faces
        and (
            climbed >= RETRY_SHARE * faces
            or small
            or (not level and _small(faces, poles, RETRY_MEDIUM))
            or (not level and fine_share(m, tol) >= FINE_SHARE)
        )
        and room
    ):
        other = _coded(m, cad, tighter, step_safe, packer, level + 1, len(data), offsets_coded)
        if other is not None:
            other.climbed = max(other.climbed, climbed)
            out = other
    if offsets_coded and _offset_bases_coded(m, t.codes):  # against the best so far
        plain = _coded(m, cad, tol, step_safe, packer, level, len(out.data), offsets_coded=False)
        if plain is not None:
            return plain
    return out


@one_blas_thread
def encode_cad(
    cad: Any,
    name: str,
    source_bytes: int,
    *,
    tol: float | None = DEFAULT_TOL_MM,
    lossless: bool = False,
    step_safe: bool = True,
    for_verify: bool = True,
) -> Encoded:
    """Code the shape of ``cad`` (an ``occ.CadFile``) into container bytes;
    ``name`` and ``source_bytes`` go to META (see :func:`compress_file`).

    ``for_verify``: the caller will run :func:`verify_encoded`.  In lossless
    mode the shape it checks is then built here, from the model, while the
    entropy stage packs the container in another thread (LZMA releases the
    GIL): the decoded model must be this model bit for bit, so it builds this
    shape.  In tolerance mode the validity stage builds it anyway."""
    m, warnings = occ.shape_to_model(cad.shape)
    bad = nonfinite(m, serialize.MAX_COORD)
    if bad is not None:  # an invalid B-rep OCCT still reads: refused in both modes alike
        raise InputError(f"{bad}: a value is not finite or out of range")
    try:  # what no reader decodes by default, even as declared, is not written
        budget.check_structure(m, budget.ADMITTED)
    except LimitError as e:
        raise UnsupportedError(f"{e}; not compressed") from None
    m.unit, m.source_format, m.product = cad.unit, cad.source_format, cad.product
    if not lossless:
        # a shape made in memory, or a part read with located faces (IGES
        # surfaces under a transformation matrix): its placements into its
        # geometry, as a STEP reader writes them (encode.placed); not an
        # assembly's
        m = placed.bake(m) or m
        # IGES cylinders and cones: surfaces of revolution of a line (encode.canonical)
        m = canonical.revolved_lines(m) or m
    meta = {
        "mode": "lossless" if lossless else "tolerance",
        "tolerance_mm": None if lossless else tol,
        "source_name": serialize.meta_text(name),
        "source_bytes": source_bytes,
        "writer": f"nurbscomp {version()}",
    }

    def packer(coded_tol: float | None) -> Packer:
        """What packs a target coded within ``coded_tol`` (None: the source
        itself, B-rep exact) into container bytes."""
        exact = coded_tol is None
        fixed = {**meta, "mode": "lossless" if exact else "tolerance", "tolerance_mm": coded_tol}
        flags = container.FLAG_LOSSLESS if exact else 0

        def pack(
            target: BRepModel,
            codes: dict[Any, Any],
            step_pcurves: bool = True,
            uncertainty: float | None = None,
        ) -> bytes:
            target.product = m.product  # exact in every mode, placements included
            # what it decodes into, for a reader to admit (budget.Limits.admit)
            declared = budget.declare(target)
            more: dict[str, Any] = {"decoded": declared} if declared else {}
            if not step_pcurves:  # STEP output without pcurves (validity.ValidityReport)
                more["step_pcurves"] = False
            if uncertainty is not None:  # its uncertainty (validity.ValidityReport)
                more["uncertainty"] = uncertainty
            sections = model_to_sections(target, {**fixed, **more}, codes)
            # lossless is the fast mode: a quick entropy search (entropy.compress)
            data = container.pack(sections, flags, thorough=not lossless)
            return _smaller_with_mode_1(data, sections, target, flags, not lossless)

        return pack

    rebuilt, built, vreport = 0, None, None
    codes: dict[Any, Any] = {}
    if lossless:
        target, lossy_report = m, None
        pack = packer(None)
        if for_verify:  # beside the build of the shape verify_encoded checks
            with ThreadPoolExecutor(1) as pool:
                packing = pool.submit(pack, target, codes)
                built = build(target)
                data = packing.result()
        else:
            data = pack(target, codes)
    else:
        assert tol is not None and tol > 0
        size = occ.diagonal(cad.shape)
        if tol > size * TOL_WARN_FRACTION:
            warnings.append(
                f"tolerance {tol:g} mm is more than {TOL_WARN_FRACTION:.0%} of the part's size "
                f"({size:.3g} mm across its bounding box): its shape may not be kept"
            )
        for i, bound in occ.thin_solids(cad.shape, tol):
            change = f"up to {bound:.0%} of it" if bound <= 1 else "more than all of it"
            warnings.append(
                f"solid {i + 1} is thin against the tolerance: faces moving by {tol:g} mm "
                f"could change its volume by {change}; a wall thinner than twice the "
                "tolerance may cross itself (a smaller --tol keeps it)"
            )
        c = _coded(m, cad, tol, step_safe, packer)
        assert c is not None  # only a tighter coding, given a ceiling, gives up
        if c.tol != tol:
            share = fine_share(m, tol)
            why = (
                f"{share:.0%} of its B-spline surfaces and curves are features finer than "
                f"{tol:g} mm, and coding the whole part tighter came out smaller"
                if share >= FINE_SHARE
                else f"within {tol:g} mm, {c.climbed} of {len(m.face_surface)} faces needed "
                "remedies (OCCT's STEP reader or BRepCheck mended them), which cost more "
                "than coding the whole part tighter"
            )
            warnings.append(f"coded within {c.tol:g} mm, not {tol:g} mm: {why}")
        t, data = c.target, c.data
        meta["tolerance_mm"] = c.tol  # what the container says (the report's coded_tolerance_mm)
        target, codes, lossy_report, rebuilt = t.model, t.codes, t.report, t.pcurves_rebuilt
        built, vreport = t.shape, t.validity
        if vreport.step_skipped:
            warnings.append(f"no STEP check: {vreport.step_skipped}")
    return Encoded(
        data,
        m,
        target,
        cad,
        meta,
        lossless,
        tol,
        step_safe,
        lossy_report,
        rebuilt,
        built,
        vreport,
        warnings,
    )


@one_blas_thread
def verify_encoded(enc: Encoded, data: bytes) -> None:
    """Decode ``data`` (the container as written) and check it against what was
    encoded: the same model bit for bit, product data, the certified bound,
    the topology counts.

    It is decoded under the limits ``decompress`` applies by default (with
    what the container declares it decodes into admitted, ``budget.Limits.admit``),
    and its output in the source's format estimated: every container
    ``compress`` writes is restored by the default command.  The pcurves the
    container leaves to compute must be within the default limits whatever
    its size (``budget.DEFAULT.pcurves`` and ``.projection``): how many it
    leaves is the writer's choice (``encode.pcurves.drop_pcurves``).

    Raises
    ------
    VerifyError
        Any difference (a bug), a limit the container is refused by, or more
        pcurves to compute than the default limits allow.
    """
    try:
        back, _ = decode(container.unpack(data), budget.DEFAULT, enc.model.source_format)
    except LimitError as e:
        raise VerifyError(f"the container is past a reader's default limits: {e}") from None
    count, work = budget.pcurves_to_compute(back)
    if count > budget.DEFAULT.pcurves or work > budget.DEFAULT.projection:
        raise VerifyError(
            f"the container leaves {count:,} pcurves ({work:,} units of work) to compute, "
            "past a reader's default limits"
        )
    diff = differences(enc.target, back)
    if enc.target.product is not None and not (
        back.product is not None and back.product.same(enc.target.product)
    ):
        diff.append("product data")
    if diff:
        raise VerifyError(f"decoded container differs from the input: {', '.join(diff)}")
    if enc.tol is not None and not enc.lossless:  # lossless: the model bit for bit, above
        worst = max_net_displacement(enc.model, back)
        if worst > enc.tol:
            raise VerifyError(f"a decoded control net moved {worst:g} mm > tol {enc.tol:g} mm")
    # the decoded model is the target bit for bit, so it builds the
    # shape built from it (by the validity stage, or beside the lossless packing)
    built = build(back) if enc.built is None else enc.built
    if occ.counts(built) != occ.counts(enc.cad.shape):
        raise VerifyError("decoded shape has other topology counts than the input")


def compress_report(enc: Encoded, verified: bool) -> dict[str, Any]:
    """The report of a compression, less ``command``, ``input``, ``output`` and times."""
    m, lossy_report, src_bytes = enc.model, enc.lossy_report, enc.meta["source_bytes"]
    return {
        "input_bytes": src_bytes,
        "output_bytes": len(enc.data),
        "ratio": src_bytes / len(enc.data) if src_bytes else None,
        "mode": enc.meta["mode"],
        "tolerance_mm": None if enc.lossless else enc.tol,
        # tol, or tol / 10 where that coded the part smaller (_coded)
        "coded_tolerance_mm": enc.meta["tolerance_mm"],
        "geometry": "exact"
        if enc.lossless
        else "B-spline surfaces and 3-D curves coded, vertices on them snapped; "
        + (
            "analytic geometry on grids where that is smaller; pcurves exact"
            if lossy_report and "analytic" in lossy_report.face_method
            else "pcurves and analytic geometry exact"
        )
        + (
            f" but the dense ones of {len(lossy_report.compacted)} edges, within "
            f"{pcurves.COMPACT_SHARE:g} tol on their surfaces"
            if lossy_report and lossy_report.compacted
            else ""
        ),
        "faces_by_method": lossy_report.method_counts() if lossy_report else {},
        "face_method_list": lossy_report.face_method if lossy_report else [],
        "max_bound_mm": float(lossy_report.face_bound.max(initial=0.0)) if lossy_report else 0.0,
        "max_curve_bound_mm": float(lossy_report.edge_bound.max(initial=0.0))
        if lossy_report
        else 0.0,
        "certified_faces": int((lossy_report.face_bound > 0).sum()) if lossy_report else 0,
        "sampled_faces": 0,
        "pcurves_rebuilt": enc.pcurves_rebuilt,
        "validity": dataclasses.asdict(enc.validity) if enc.validity else {},
        "step_safe": enc.step_safe and not enc.lossless,
        "unit": m.unit,
        "source_format": m.source_format,
        "counts": occ.counts(enc.cad.shape),
        "faces_by_type": faces_by_type(m),
        "product": product.summary(m.product) if m.product is not None else None,
        "product_bytes": (
            len(product.write(m.product, (m.child_start, m.child_shape)))
            if m.product is not None
            else 0
        ),
        "verified": verified,
        "warnings": [*enc.cad.warnings, *enc.warnings],
    }


def max_net_displacement(a: BRepModel, b: BRepModel) -> float:
    """Largest certified move between the B-spline surfaces and 3-D curves of two models.

    The certified bound of docs/design.md §4: knots and degrees are equal, so no
    point of a surface or curve moves further than its farthest pole, plus
    what its rounded weights and knots add (:func:`encode.knots.moved`); a
    row with inner knots removed is compared on the source's knots
    (:func:`encode.knots.raised`); an offset surface whose basis moved, by
    :func:`encode.offsets.moved`.
    """
    worst = 0.0
    pairs = [*zip(a.surfaces, b.surfaces), *zip(a.curves3d, b.curves3d)]
    for x, y in pairs:
        if isinstance(x, (BSplineSurface, BSplineCurve)) and type(x) is type(y):
            worst = max(worst, knots.moved(y, x))  # inf for other poles
    for s in a.surfaces:  # an offset moves by more than its basis (encode.offsets)
        if isinstance(s, Derived) and s.kind == Kind.OFFSET_SURFACE:
            x, y = a.surfaces[s.basis], b.surfaces[s.basis]
            if isinstance(x, BSplineSurface) and x is not y:
                box = offsets.face_box(a, s.basis)
                worst = max(worst, offsets.moved(x, y, float(s.params[0]), box))
    return worst


#: A container of at most this many bytes is also packed with its SHAP in
#: mode 1, and the smaller kept (:func:`_smaller_with_mode_1`).
MODE_1_SMALL = 2048


def _smaller_with_mode_1(
    data: bytes, sections: list[tuple[str, bytes]], m: BRepModel, flags: int, thorough: bool
) -> bytes:
    """``data``, or the same sections packed with ``m``'s SHAP in mode 1
    where that is smaller (docs/format.md §2.5.1): the dictionary coders
    (§1.3) hold earlier writers' mode-1 streams of common small models bit
    for bit (a one-face part: 281 bytes in 2.18, 302 with mode 2).  Only
    for a container of at most :data:`MODE_1_SMALL` bytes."""
    if len(data) > MODE_1_SMALL:
        return data
    one = serialize.walk_section(m)
    if one is None:
        return data
    alt = [(tag, one if tag == "SHAP" else raw) for tag, raw in sections]
    if alt == sections:
        return data
    other = container.pack(alt, flags, thorough=thorough)
    return other if len(other) < len(data) else data
