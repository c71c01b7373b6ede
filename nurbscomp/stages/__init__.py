"""The stages ``pipeline`` wires into commands: :mod:`.compress`,
:mod:`.decompress`, :mod:`.evaluate`, and what they share (:mod:`.common`).
Each works in memory on models, shapes and bytes; ``pipeline`` adds the
paths, atomic outputs and reports."""
