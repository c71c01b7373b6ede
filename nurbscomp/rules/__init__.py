"""Rules both sides run, frozen by the format (docs/format.md).

The encoder predicts with them what the decoder will compute, and the decoder
computes it: a change here changes what containers already written decode
to.  So nothing here is an encoder's heuristic (those live in
:mod:`nurbscomp.encode`), and nothing reaches OCCT.

* :mod:`.nets`: what a net's coding needs of its surface (the Greville
  abscissae of the Coons blend, the D-map's basis);
* :mod:`.ranges`: the edge-range rules (docs/format.md §2.7);
* :mod:`.joins`: where decoded neighbours must meet: corners and curve ends
  pinned to vertices, curves anchored at them, sides joined, copies placed
  (docs/format.md §2.4, §2.9, §2.10).
"""
