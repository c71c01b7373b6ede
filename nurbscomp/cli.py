"""The command line.  The only module that prints or exits.

Exit codes: 0 ok; 1 bad input, bad container, output exists, or any other
failure on a file; 2 usage; 130 interrupted.  Errors are one line,
``error: FILE: message``, on stderr; ``--debug`` adds the traceback.  README,
"Exit codes and errors", lists every error class.
"""

from __future__ import annotations

import json
import sys
import traceback
from collections.abc import Callable
from functools import partial
from typing import Any

import click

from . import __version__, pipeline
from .errors import NurbscompError
from .units import parse_length


class _Length(click.ParamType):
    name = "LENGTH"

    def convert(self, value: Any, param: Any, ctx: Any) -> float:
        if isinstance(value, float):
            return value
        try:
            return parse_length(str(value))
        except ValueError as e:
            self.fail(str(e), param, ctx)


class _State:
    def __init__(self, debug: bool) -> None:
        self.debug = debug
        self.failed = False


def _run(state: _State, path: str, fn: Callable[[], dict[str, Any]]) -> dict[str, Any] | None:
    """Run one file's work; turn any failure into one ``error:`` line."""
    try:
        return fn()
    except KeyboardInterrupt:
        click.echo(f"error: {path}: interrupted", err=True)
        sys.exit(130)
    except NurbscompError as e:
        msg = str(e)
    except MemoryError:
        msg = "out of memory"
    except Exception as e:  # an OCCT or internal failure: still one line
        msg = f"internal error ({type(e).__name__}: {e}); rerun with --debug for details"
    if state.debug:
        traceback.print_exc()
    click.echo(f"error: {path}: {msg}", err=True)
    state.failed = True
    return None


def _fmt_counts(c: dict[str, int]) -> str:
    return ", ".join(f"{v} {k}" for k, v in c.items())


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "-V", "--version", prog_name="nurbscomp")
@click.option("--debug", is_flag=True, help="Show a traceback on errors.")
@click.pass_context
def cli(ctx: click.Context, debug: bool) -> None:
    """Compress STEP and IGES B-reps into .nzc containers, and back to STEP.

    \b
    Examples:
      nurbscomp compress part.step            # -> part.step.nzc (tol 0.01 mm)
      nurbscomp compress --lossless *.stp     # exact geometry
      nurbscomp decompress part.step.nzc      # -> part.step
      nurbscomp decompress a.nzc -o a.igs     # IGES (or .brep) by extension
      nurbscomp info part.step.nzc --json

    \b
    Exit codes: 0 ok; 1 bad input, damaged container, output exists or any
    other failure on a file; 2 bad usage; 130 interrupted (Ctrl-C).
    """
    ctx.obj = _State(debug)


def _outputs(files: tuple[str, ...], output: str | None) -> list[str | None]:
    if output is not None and len(files) > 1:
        raise click.UsageError("-o/--output takes a single input file")
    return [output] if output is not None else [None] * len(files)


def _emit(
    reports: list[dict[str, Any]], as_json: bool, text: Callable[[dict[str, Any]], str]
) -> None:
    for r in reports:
        click.echo(json.dumps(r, sort_keys=True) if as_json else text(r))


def _progress(items: list[Any], quiet: bool, label: str) -> Any:
    if quiet or len(items) < 2 or not sys.stderr.isatty():
        return _NoBar(items)
    return click.progressbar(items, label=label, file=sys.stderr)


class _NoBar:
    def __init__(self, items: list[Any]) -> None:
        self.items = items

    def __enter__(self) -> list[Any]:
        return self.items

    def __exit__(self, *exc: Any) -> None:
        return None


def _batch_options(verbose_help: str) -> Callable[[Any], Any]:
    """The options every file-converting command shares, like xz and zstd."""

    def wrap(f: Any) -> Any:
        for opt in reversed(
            [
                click.option("-f", "--force", is_flag=True, help="Overwrite existing outputs."),
                click.option(
                    "--json", "as_json", is_flag=True, help="One JSON report per file on stdout."
                ),
                click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors."),
                click.option("-v", "--verbose", is_flag=True, help=verbose_help),
            ]
        ):
            f = opt(f)
        return f

    return wrap


def _batch(
    state: _State,
    files: tuple[str, ...],
    output: str | None,
    label: str,
    work: Callable[[str, str | None], dict[str, Any]],
    text: Callable[[dict[str, Any]], str],
    as_json: bool,
    quiet: bool,
) -> None:
    """Run ``work`` on each file, report each result, exit 1 if any file failed."""
    reports = []
    with _progress(list(zip(files, _outputs(files, output))), quiet or as_json, label) as bar:
        for f, o in bar:
            r = _run(state, f, partial(work, f, o))
            if r is None:
                continue
            reports.append(r)
            if not as_json and not quiet:
                click.echo(text(r))
            for w in r.get("warnings", []) if not (quiet or as_json) else []:
                click.echo(f"warning: {f}: {w}", err=True)
    if as_json:
        _emit(reports, True, str)
    sys.exit(1 if state.failed else 0)


@cli.command()
@click.argument("files", nargs=-1, required=True, type=click.Path())
@click.option("-o", "--output", type=click.Path(), help="Output file (one input only).")
@click.option("--lossless", is_flag=True, help="Keep every number bit for bit.")
@click.option(
    "--tol",
    type=_Length(),
    default=None,
    help=f"Tolerance, mm unless suffixed (um, in, mil...). Default {pipeline.DEFAULT_TOL_MM} mm.",
)
@click.option("--no-verify", is_flag=True, help="Skip decoding the output to check it.")
@click.option(
    "--step-safe/--no-step-safe",
    default=True,
    show_default=True,
    help="Keep exact what OCCT's STEP reader would 'repair' when reading the "
    "decompressed STEP back (same topology as OCCT's own round trip). "
    "--no-step-safe: smaller files; the decoded B-rep is still valid and within tol.",
)
@_batch_options("Print counts and faces by type.")
@click.pass_obj
def compress(
    state: _State,
    files: tuple[str, ...],
    output: str | None,
    lossless: bool,
    tol: float | None,
    no_verify: bool,
    step_safe: bool,
    force: bool,
    as_json: bool,
    quiet: bool,
    verbose: bool,
) -> None:
    """Compress STEP/IGES FILES to FILE.nzc (the input is kept)."""
    if lossless and tol is not None:
        raise click.UsageError("--lossless and --tol exclude each other")
    if tol is None and not lossless and not quiet and not as_json:
        click.echo(f"tolerance {pipeline.DEFAULT_TOL_MM} mm (default; --tol to change)", err=True)
    tol_mm = tol if tol is not None else pipeline.DEFAULT_TOL_MM

    def work(f: str, o: str | None) -> dict[str, Any]:
        return pipeline.compress_file(
            f,
            o,
            tol=tol_mm,
            lossless=lossless,
            force=force,
            verify=not no_verify,
            step_safe=step_safe,
        )

    _batch(
        state, files, output, "compress", work, lambda r: _compress_text(r, verbose), as_json, quiet
    )


def _compress_text(r: dict[str, Any], verbose: bool) -> str:
    mode = "lossless" if r["mode"] == "lossless" else f"tol {r['tolerance_mm']:g} mm"
    line = (
        f"{r['input']} -> {r['output']}: {r['input_bytes']} -> {r['output_bytes']} bytes "
        f"({r['ratio']:.1f}x, {mode}, {r['seconds']:.2f} s"
        f"{', verified' if r['verified'] else ''})"
    )
    if verbose:
        line += f"\n  {_fmt_counts(r['counts'])}; unit {r['unit']}; faces by type: "
        line += ", ".join(f"{v} {k}" for k, v in r["faces_by_type"].items())
        if r["faces_by_method"]:
            line += "\n  faces by method: "
            line += ", ".join(f"{v} {k}" for k, v in sorted(r["faces_by_method"].items()))
        v = r.get("validity") or {}
        if v:
            kept = ", ".join(f"{n} ({why})" for why, n in v["exact_faces"].items()) or "none"
            line += (
                f"\n  validity: rounds {v['rounds']}, STEP round trips {v['step_round_trips']};"
                f" faces kept exact: {kept}; faces with stored pcurves: {v['pcurves_kept']}"
            )
            if v["step_skipped"]:
                line += f"; no STEP check: {v['step_skipped']}"
        p = r.get("product")
        if p:
            line += (
                f"\n  product: {p['parts']} parts, {p['assemblies']} assemblies, "
                f"{p['instances']} instances, {p['colours']} colours, {p['layers']} layers "
                f"({r.get('product_bytes', 0)} bytes raw)"
            )
    return line


@cli.command()
@click.argument("files", nargs=-1, required=True, type=click.Path())
@click.option(
    "-o", "--output", type=click.Path(), help="Output file: .step (default), .igs, .brep."
)
@_batch_options("Print topology counts.")
@click.pass_obj
def decompress(
    state: _State,
    files: tuple[str, ...],
    output: str | None,
    force: bool,
    as_json: bool,
    quiet: bool,
    verbose: bool,
) -> None:
    """Decode .nzc FILES back to STEP (or IGES/BREP by the -o extension)."""

    def text(r: dict[str, Any]) -> str:
        line = f"{r['input']} -> {r['output']}: {r['format']} in {r['unit']}"
        line += f", {r['seconds']:.2f} s"
        return line + (f"\n  {_fmt_counts(r['counts'])}" if verbose else "")

    _batch(
        state,
        files,
        output,
        "decompress",
        lambda f, o: pipeline.decompress_file(f, o, force=force),
        text,
        as_json,
        quiet,
    )


@cli.command()
@click.argument("file", type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
@click.pass_obj
def info(state: _State, file: str, as_json: bool) -> None:
    """Show what a .nzc container holds."""
    r = _run(state, file, lambda: pipeline.info(file))
    if r is None:
        sys.exit(1)
    if as_json:
        click.echo(json.dumps(r, sort_keys=True))
        return
    mode = "lossless" if r["mode"] == "lossless" else f"tolerance {r['tolerance_mm']:g} mm"
    lines = [
        f"file:        {r['input']} ({r['file_bytes']} bytes)",
        f"format:      .nzc {r['format_version']}, body coded with {r['coder']}",
        f"mode:        {mode}",
        f"source:      {r['source_name']} ({r['source_format']}, "
        f"{r['source_bytes']} bytes, unit {r['unit']})",
        f"ratio:       {r['source_bytes'] / r['file_bytes']:.1f}x",
        f"shapes:      {_fmt_counts(r['shapes'])}",
        "faces:       " + ", ".join(f"{v} {k}" for k, v in r["faces_by_type"].items()),
        f"geometry:    {_fmt_counts(r['geometry'])}",
        "sections:    "
        + ", ".join(f"{k} {v}" for k, v in r["section_raw_bytes"].items())
        + f" bytes raw; {r['body_stored_bytes']} bytes coded",
        *_product_lines(r.get("product")),
    ]
    click.echo("\n".join(lines))


def _product_lines(p: dict[str, Any] | None) -> list[str]:
    """``info``'s product summary (format 1.2), or a line saying there is none."""
    if p is None:
        return ["product:     none stored (a format 1.0/1.1 container, or none in the source)"]
    coloured = ", ".join(f"{v} {k}s" for k, v in p["coloured"].items()) or "nothing"
    return [
        f"product:     {p['parts']} parts, {p['assemblies']} assemblies, "
        f"{p['instances']} instances, depth {p['depth']}, {p['named']} names",
        f"colours:     {p['colours']} colours on {coloured}",
        f"layers:      {p['layers']}",
        f"schema:      {', '.join(p['schema']) or '-'}",
        f"dropped:     {'; '.join(p['dropped']) or 'nothing'}",
    ]


@cli.command("test")
@click.argument("files", nargs=-1, required=True, type=click.Path())
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
@click.pass_obj
def test_cmd(state: _State, files: tuple[str, ...], quiet: bool) -> None:
    """Check .nzc FILES: checksums, references, and a full rebuild (like xz -t)."""
    for f in files:
        r = _run(state, f, partial(pipeline.test_file, f))
        if r is not None and not quiet:
            click.echo(f"{f}: OK ({r['faces']} faces)")
    sys.exit(1 if state.failed else 0)


@cli.command("eval")
@click.argument("original", type=click.Path())
@click.argument("reconstructed", type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
@click.pass_obj
def eval_cmd(state: _State, original: str, reconstructed: str, as_json: bool) -> None:
    """Compare two CAD files (STEP, IGES or .nzc): deviation, topology, validity.

    Faces are paired by index; points sampled inside each ORIGINAL face are
    measured against the RECONSTRUCTED face of the same index.
    """
    r = _run(state, reconstructed, lambda: pipeline.evaluate(original, reconstructed))
    if r is None:
        sys.exit(1)
    if as_json:
        click.echo(json.dumps(r, sort_keys=True))
        return
    lines = [
        f"topology:    {_fmt_counts(r['counts']['original'])}",
        f"             {_fmt_counts(r['counts']['reconstructed'])}"
        + ("" if r["same_topology"] else "  (differs)"),
        f"valid:       {r['valid']['original']} -> {r['valid']['reconstructed']}",
        f"free edges:  {r['free_edges']['original']} -> {r['free_edges']['reconstructed']}",
    ]
    if "max_deviation_mm" in r:
        lines.append(
            f"deviation:   max {r['max_deviation_mm']:.3g} mm, mean {r['mean_deviation_mm']:.3g} mm"
        )
        lines.append(
            "worst faces: "
            + ", ".join(f"#{w['face']} {w['max_mm']:.3g} mm" for w in r["worst_faces"])
        )
    click.echo("\n".join(lines))


def main() -> None:
    """Console-script entry point."""
    cli(prog_name="nurbscomp")


if __name__ == "__main__":
    main()
