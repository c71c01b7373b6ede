"""cadquery objects <-> OCP shapes, for the Python API (``nurbscomp._api``).

cadquery is imported here only, and only when a function needs it (it takes a
second or more on top of OCP): an object is recognised as cadquery's by the
module its class comes from, which is then imported already.
"""

from __future__ import annotations

import os
from typing import Any

from OCP.TopoDS import TopoDS_Shape

from ..errors import InputError


def _from_cadquery(obj: Any) -> bool:
    return type(obj).__module__.split(".")[0] == "cadquery"


def is_assembly(obj: Any) -> bool:
    """Whether ``obj`` is a ``cadquery.Assembly``."""
    if not _from_cadquery(obj):
        return False
    import cadquery as cq

    return isinstance(obj, cq.Assembly)


def to_topods(obj: Any) -> Any | None:
    """The ``TopoDS_Shape`` of an OCP shape, a ``cadquery.Shape`` (its
    ``wrapped``) or a ``cadquery.Workplane`` (its one shape, or a compound of
    its shapes); None for any other object.

    Raises
    ------
    InputError
        A Workplane that holds no shape.
    """
    if isinstance(obj, TopoDS_Shape):
        return obj
    if not _from_cadquery(obj):
        return None
    import cadquery as cq

    if isinstance(obj, cq.Shape):
        return obj.wrapped
    if isinstance(obj, cq.Workplane):
        shapes = [v for v in obj.vals() if isinstance(v, cq.Shape)]
        if not shapes:
            raise InputError("the Workplane holds no shape")
        if len(shapes) == 1:
            return shapes[0].wrapped
        return cq.Compound.makeCompound(shapes).wrapped
    if isinstance(obj, cq.Assembly):
        return obj.toCompound().wrapped
    return None


def write_assembly(assy: Any, path: str | os.PathLike[str]) -> None:
    """Write a ``cadquery.Assembly`` to STEP with its tree, names and colours
    (cadquery's XDE writer)."""
    assy.export(os.fspath(path), "STEP")


def to_cadquery(shape: Any) -> Any:
    """A ``TopoDS_Shape`` as the ``cadquery.Shape`` subclass of its type."""
    import cadquery as cq

    return cq.Shape.cast(shape)


def to_assembly(product: Any, root: Any) -> Any:
    """A ``cadquery.Assembly`` of a decoded shape and its product data
    (``nurbscomp.product.ProductData``): the XDE document that the STEP
    writer gets (``xcaf.to_document``), read by cadquery's own XDE reader
    (the one behind ``cadquery.Assembly.importStep``)."""
    import cadquery as cq
    from cadquery.occ_impl.importers.assembly import _importDoc

    from . import xcaf

    doc = xcaf.to_document(product, xcaf.shape_rows(root)[2])
    assy = cq.Assembly()
    _importDoc(doc, assy)
    return assy
