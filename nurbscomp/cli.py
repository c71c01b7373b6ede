"""The command line.  The only module that prints or exits.

Exit codes: 0 ok; 1 bad input, bad container, output exists, or any other
failure on a file (a batch exits with its worst file's code); 2 usage;
128 + the signal's number when interrupted (130 SIGINT, 129 SIGHUP, 143
SIGTERM).  Errors are one line,
``error: FILE: message``, on stderr; ``--debug`` adds the traceback.  README,
"Exit codes and errors", lists every error class.
"""

from __future__ import annotations

import json
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable
from functools import partial
from typing import Any

import click

from . import __version__
from .errors import NurbscompError
from .units import DEFAULT_TOL_MM, parse_length


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


class Interrupted(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised like Ctrl-C's ``KeyboardInterrupt`` so that the
    file being written is removed (``pipeline.atomic_output``)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def _raise_interrupted(signum: int, frame: Any) -> None:
    raise Interrupted(signum)


def catch_signals() -> None:
    """Handle SIGTERM and SIGHUP like SIGINT (unless they are ignored, as under
    ``nohup``).  SIGKILL cannot be caught: it leaves the temporary file."""
    for sig in (signal.SIGTERM, signal.SIGHUP):
        if signal.getsignal(sig) is signal.SIG_DFL:
            signal.signal(sig, _raise_interrupted)


def show(x: Any) -> str:
    """``x`` as text safe for a terminal: every character that is not printable
    (control characters such as CR and BEL, lone surrogates, format characters)
    escaped as Python writes it (``\\r``, ``\\x07``, ``\\u202e``)."""
    s = str(x)
    if s.isprintable():
        return s
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in s)


def _interrupted(e: KeyboardInterrupt, names: list[str]) -> None:
    """Report an interrupt (one line per file being worked on) and exit 128 + signal."""
    signum = e.signum if isinstance(e, Interrupted) else signal.SIGINT
    name = "interrupted"
    if signum != signal.SIGINT:
        name += f" ({signal.Signals(signum).name})"
    for path in names or ["batch"]:
        click.echo(f"error: {show(path)}: {name}", err=True)
    sys.exit(128 + signum)


def _error(state: _State, path: str, msg: str, tb: str | None) -> None:
    """One ``error:`` line on stderr, after the traceback with ``--debug``."""
    if state.debug and tb:
        click.echo(tb.rstrip("\n"), err=True)
    click.echo(f"error: {show(path)}: {show(msg)}", err=True)
    state.failed = True


def _run(state: _State, path: str, fn: Callable[[], dict[str, Any]]) -> dict[str, Any] | None:
    """Run one file's work; turn any failure into one ``error:`` line."""
    try:
        return fn()
    except KeyboardInterrupt as e:
        _interrupted(e, [path])
    except NurbscompError as e:
        msg, tb = str(e), traceback.format_exc()
    except MemoryError:
        msg, tb = "out of memory", traceback.format_exc()
    except Exception as e:  # an OCCT or internal failure: still one line
        msg = f"internal error ({type(e).__name__}: {e}); rerun with --debug for details"
        tb = traceback.format_exc()
    _error(state, path, msg, tb)
    return None


def _fmt_counts(c: dict[str, int]) -> str:
    return ", ".join(f"{v} {k}" for k, v in c.items())


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "-V", "--version", prog_name="nurbscomp")
@click.option("--debug", is_flag=True, help="Show the traceback of each error.")
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
    Batches, pipes:
      nurbscomp compress -r parts/ -d archive/ -j 4 --json > report.jsonl
      nurbscomp compress -r parts/ -d archive/ --skip-existing   # resume
      nurbscomp decompress -r archive/ -d back/                  # mirror the tree
      nurbscomp compress -r parts/ -d archive/ --scheduler tcp://host:8786
      cat part.step | nurbscomp compress - -c > part.nzc
      nurbscomp decompress -c --format step part.nzc | head

    \b
    Exit codes: 0 ok; 1 bad input, damaged container, output exists or any
    other failure on a file (a batch exits with its worst file's code);
    2 bad usage; 130 interrupted (Ctrl-C), 143 terminated (SIGTERM), 129 hung
    up (SIGHUP).
    """
    ctx.obj = _State(debug)


def _limit_scale(f: Any) -> Any:
    """``--limit-scale K``: the decoding budget times K (docs/format.md §4)."""
    return click.option(
        "--limit-scale",
        type=click.FloatRange(min=0, min_open=True),
        default=1.0,
        show_default=True,
        metavar="K",
        # the limits' values are not printed: budget imports numpy, and --help
        # starts without it
        help="Multiply the decoding limits (references once sharing is unfolded, "
        "nesting depth, poles, pcurves to compute, estimated output size; "
        "docs/format.md §4) by K, for a container that is trusted and larger "
        "than they allow.",
    )(f)


def _batch_options(verbose_help: str) -> Callable[[Any], Any]:
    """The options every file-converting command shares, like xz and zstd."""

    def wrap(f: Any) -> Any:
        for opt in reversed(
            [
                click.option(
                    "-o", "--output", type=click.Path(), help="Output file (one input; -: stdout)."
                ),
                click.option(
                    "-d",
                    "--output-dir",
                    type=click.Path(file_okay=False),
                    help="Write outputs here, mirroring the folders walked by -r.",
                ),
                click.option(
                    "-r", "--recursive", is_flag=True, help="Walk folders given as inputs."
                ),
                click.option("-c", "--stdout", "to_stdout", is_flag=True, help="Write to stdout."),
                click.option(
                    "-j",
                    "--jobs",
                    type=click.IntRange(min=0),
                    default=0,
                    help="Worker processes (default 0: one per core; 1: no workers).",
                ),
                click.option(
                    "--scheduler",
                    metavar="tcp://HOST:PORT",
                    help="Run the files on this Dask cluster (sent as bytes).",
                ),
                click.option("-f", "--force", is_flag=True, help="Overwrite existing outputs."),
                click.option(
                    "--skip-existing", is_flag=True, help="Skip files whose output exists (resume)."
                ),
                click.option(
                    "--json",
                    "as_json",
                    is_flag=True,
                    help="One JSON line per file, failures included, then a summary line.",
                ),
                click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors."),
                click.option("-v", "--verbose", is_flag=True, help=verbose_help),
            ]
        ):
            f = opt(f)
        return f

    return wrap


def _mb(n: int) -> str:
    return f"{n / 1e6:.2f} MB" if n >= 10**5 else f"{n} bytes"


class _Bar:
    """A progress bar on stderr (tqdm) when stderr is a terminal and the batch
    lasts more than a second: files done, bytes, ratio so far, ETA; and, for
    files done in this process, the file's stage (read, code, write, check),
    redrawn every half second."""

    DELAY = 1.0

    def __init__(self, total: int, show_bar: bool) -> None:
        self.bar: Any = None
        self.bytes_in = self.bytes_out = 0
        self.done = threading.Event()
        if show_bar:
            from tqdm import tqdm

            self.bar = tqdm(
                total=total, unit="file", file=sys.stderr, delay=self.DELAY, leave=False
            )
            threading.Thread(target=self._tick, daemon=True).start()

    def _tick(self) -> None:
        while not self.done.wait(0.5):
            if time.time() - self.bar.start_t >= self.DELAY:
                self.bar.refresh()

    def stage(self, what: str) -> None:
        """The runner's stage callback: show ``FILE: stage``."""
        if self.bar is not None:
            self.bar.set_description_str(show(what), refresh=False)

    def update(self, r: dict[str, Any]) -> None:
        if self.bar is None:
            return
        if r["status"] == "ok":
            self.bytes_in += r.get("input_bytes", 0)
            self.bytes_out += r.get("output_bytes", 0)
        if self.bytes_in and self.bytes_out:
            self.bar.set_postfix_str(
                f"{_mb(self.bytes_in)} -> {_mb(self.bytes_out)}, "
                f"{self.bytes_in / self.bytes_out:.1f}x",
                refresh=False,
            )
        self.bar.update(1)

    def write(self, text: str, err: bool) -> None:
        """Print a line without breaking the bar."""
        if self.bar is not None:
            self.bar.clear()
        click.echo(text, err=err)
        if self.bar is not None:
            self.bar.refresh()

    def close(self) -> None:
        self.done.set()
        if self.bar is not None:
            self.bar.close()


def _batch(
    state: _State,
    files: tuple[str, ...],
    opts: Any,
    kw: dict[str, Any],
    text: Callable[[dict[str, Any]], str],
) -> None:
    """Plan the tasks, run them (here, in workers or on a cluster), print a line
    per file and a summary; exit with the worst file's code."""
    from . import batch

    as_json, quiet = kw["as_json"], kw["quiet"]
    try:
        tasks = batch.plan(
            list(files),
            opts,
            recursive=kw["recursive"],
            output=kw["output"],
            output_dir=kw["output_dir"],
            to_stdout=kw["to_stdout"],
        )
    except batch.UsageError as e:
        raise click.UsageError(str(e)) from None
    to_stdout = any(t.dst is None for t in tasks)
    if to_stdout and sys.stdout.isatty() and (opts.command == "compress" or opts.fmt == "BREP"):
        raise click.UsageError("refusing to write binary data to a terminal (redirect, or -o)")
    if any(t.src == batch.STDIO for t in tasks) and sys.stdin.isatty():
        raise click.UsageError("refusing to read data from a terminal (pipe a file into -)")
    if opts.command == "compress" and opts.tol is not None and not opts.lossless:
        if kw["tol"] is None and not quiet and not as_json:
            click.echo(
                f"tolerance {opts.tol} mm (default; --tol to change)",
                err=True,
            )
    jobs = kw["jobs"] or batch.cores()
    show_bar = not quiet and len(tasks) > 0 and sys.stderr.isatty()
    bar = _Bar(len(tasks), show_bar)
    runner = batch.Runner(
        tasks,
        opts,
        jobs,
        kw["scheduler"],
        read_stdin=lambda: sys.stdin.buffer.read(),
        stage=bar.stage if show_bar else None,
    )
    say_err = to_stdout  # the data owns stdout
    records: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    gen = runner.records()
    try:
        for r, blob in gen:
            if blob is not None:
                sys.stdout.buffer.write(blob)
                sys.stdout.buffer.flush()
            records.append(r)
            bar.update(r)
            _report(state, r, as_json, quiet, text, bar, say_err)
    except KeyboardInterrupt as e:
        gen.close()
        bar.close()
        _interrupted(e, runner.running)
    except batch.SchedulerError as e:
        bar.close()
        click.echo(f"error: {show(kw['scheduler'])}: {show(e)}", err=True)
        sys.exit(1)
    finally:
        gen.close()
        bar.close()
    s = batch.summary(records, time.perf_counter() - t0)
    if as_json:
        click.echo(json.dumps(s, sort_keys=True), err=say_err)
    elif not quiet and len(records) > 1:
        ratio = f", {s['ratio']:.1f}x" if s["ratio"] else ""
        click.echo(
            f"{s['files']} files: {s['ok']} ok ({s['passthrough']} stored verbatim), "
            f"{s['failed']} failed, {s['skipped']} skipped; "
            f"{_mb(s['bytes_in'])} -> {_mb(s['bytes_out'])}{ratio}; {s['seconds']:.1f} s",
            err=say_err,
        )
    sys.exit(s["exit_code"])


def _report(
    state: _State,
    r: dict[str, Any],
    as_json: bool,
    quiet: bool,
    text: Callable[[dict[str, Any]], str],
    bar: _Bar,
    err: bool,
) -> None:
    """Print one file's record: a JSON line, or text; its error or warnings on stderr."""
    if r["status"] == "failed":
        if state.debug and r.get("traceback"):
            bar.write(r["traceback"].rstrip("\n"), True)
        bar.write(f"error: {show(r['input'])}: {show(r['error'])}", True)
        state.failed = True
    if as_json:
        bar.write(json.dumps({k: v for k, v in r.items() if k != "traceback"}, sort_keys=True), err)
        return
    if quiet:
        return
    if r["status"] == "skipped":
        bar.write(f"{show(r['input'])}: skipped ({show(r['output'])} exists)", err)
    elif r["status"] == "ok":
        bar.write("\n".join(show(line) for line in text(r).split("\n")), err)
        for w in r.get("warnings", []):
            bar.write(f"warning: {show(r['input'])}: {show(w)}", True)


@cli.command()
@click.argument("files", nargs=-1, required=True, type=click.Path())
@click.option("--lossless", is_flag=True, help="Keep every number bit for bit.")
@click.option(
    "--tol",
    type=_Length(),
    default=None,
    help=f"Tolerance, mm unless suffixed (um, in, mil...). Default {DEFAULT_TOL_MM} mm.",
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
    lossless: bool,
    tol: float | None,
    no_verify: bool,
    step_safe: bool,
    verbose: bool,
    **kw: Any,
) -> None:
    """Compress STEP/IGES FILES to FILE.nzc (the input is kept).

    FILES may be folders (with -r) and - (standard input, to standard output
    unless -o).  A valid STEP/IGES file that holds no B-rep (tessellated,
    curves only) is stored verbatim, with a warning.
    """
    from .batch import Options

    if lossless and tol is not None:
        raise click.UsageError("--lossless and --tol exclude each other")
    opts = Options(
        "compress",
        force=kw["force"],
        skip_existing=kw["skip_existing"],
        tol=None if lossless else (tol if tol is not None else DEFAULT_TOL_MM),
        lossless=lossless,
        verify=not no_verify,
        step_safe=step_safe,
        debug=state.debug,
    )
    _batch(state, files, opts, {**kw, "tol": tol}, lambda r: _compress_text(r, verbose))


def _compress_text(r: dict[str, Any], verbose: bool) -> str:
    if r["mode"] == "passthrough":
        return (
            f"{r['input']} -> {r['output']}: {r['input_bytes']} -> {r['output_bytes']} bytes "
            f"({r['ratio']:.1f}x, stored verbatim, {r['seconds']:.2f} s"
            f"{', verified' if r['verified'] else ''})"
        )
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
                f" faces coded tighter: {v['tightened']}; faces kept exact: {kept};"
                f" faces with stored pcurves: {v['pcurves_kept']}"
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
    "--format",
    "fmt",
    type=click.Choice(["step", "iges", "brep"], case_sensitive=False),
    help="Output format (needed with -c; default: by -o's extension, else STEP).",
)
@_limit_scale
@_batch_options("Print topology counts.")
@click.pass_obj
def decompress(
    state: _State, files: tuple[str, ...], fmt: str | None, verbose: bool, **kw: Any
) -> None:
    """Decode .nzc FILES back to STEP (or IGES/BREP by --format or the -o extension).

    FILES may be folders (with -r) and - (standard input).  A passthrough
    container gives back the exact bytes of the file it holds.
    """
    from .batch import Options

    opts = Options(
        "decompress",
        force=kw["force"],
        skip_existing=kw["skip_existing"],
        fmt=fmt.upper() if fmt else None,
        debug=state.debug,
        limit_scale=kw.pop("limit_scale"),
    )

    def text(r: dict[str, Any]) -> str:
        if r.get("passthrough"):
            return f"{r['input']} -> {r['output']}: {r['format']} stored verbatim, exact bytes"
        line = f"{r['input']} -> {r['output']}: {r['format']} in {r['unit']}"
        line += f", {r['seconds']:.2f} s"
        return line + (f"\n  {_fmt_counts(r['counts'])}" if verbose else "")

    _batch(state, files, opts, kw, text)


@cli.command()
@click.argument("file", type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
@_limit_scale
@click.pass_obj
def info(state: _State, file: str, as_json: bool, limit_scale: float) -> None:
    """Show what a .nzc container holds."""
    from . import budget, pipeline

    r = _run(state, file, lambda: pipeline.info(file, budget.DEFAULT.scaled(limit_scale)))
    if r is None:
        sys.exit(1)
    if as_json:
        click.echo(json.dumps(r, sort_keys=True))
        return
    if r.get("passthrough"):
        lines = [
            f"file:        {r['input']} ({r['file_bytes']} bytes)",
            f"format:      .nzc {r['format_version']}, body coded with {r['coder']}",
            f"mode:        passthrough (the file stored verbatim: {r['reason']})",
            f"source:      {r['source_name']} ({r['source_format']}, {r['source_bytes']} bytes)",
            f"ratio:       {r['source_bytes'] / r['file_bytes']:.1f}x",
        ]
        click.echo("\n".join(show(line) for line in lines))
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
    click.echo("\n".join(show(line) for line in lines))


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
@_limit_scale
@click.pass_obj
def test_cmd(state: _State, files: tuple[str, ...], quiet: bool, limit_scale: float) -> None:
    """Check .nzc FILES: checksums, references, the decoding limits, and a full
    rebuild (like xz -t)."""
    from . import budget, pipeline

    limits = budget.DEFAULT.scaled(limit_scale)
    for f in files:
        r = _run(state, f, partial(pipeline.test_file, f, limits))
        if r is not None and not quiet:
            what = "stored verbatim" if r.get("passthrough") else f"{r['faces']} faces"
            click.echo(f"{show(f)}: OK ({what})")
    sys.exit(1 if state.failed else 0)


@cli.command("eval")
@click.argument("original", type=click.Path())
@click.argument("reconstructed", type=click.Path())
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
@click.option(
    "--heatmap",
    type=click.Path(dir_okay=False),
    metavar="PNG",
    help="Also draw the reconstructed model, each face coloured by its deviation, to PNG.",
)
@click.option(
    "--tol",
    type=_Length(),
    default=None,
    help="Tolerance marked on the heatmap (default: the container's, if RECONSTRUCTED is one).",
)
@click.option("-f", "--force", is_flag=True, help="Overwrite an existing PNG.")
@click.pass_obj
def eval_cmd(
    state: _State,
    original: str,
    reconstructed: str,
    as_json: bool,
    heatmap: str | None,
    tol: float | None,
    force: bool,
) -> None:
    """Compare two CAD files (STEP, IGES or .nzc): deviation, topology, validity.

    Faces are paired by index; points sampled inside each ORIGINAL face are
    measured against the RECONSTRUCTED face of the same index.  --heatmap
    renders the RECONSTRUCTED model offscreen with a colour bar in mm, the
    tolerance marked and the worst face on its own.
    """
    from . import pipeline

    r = _run(
        state,
        reconstructed,
        lambda: pipeline.evaluate(original, reconstructed, tol=tol, heatmap=heatmap, force=force),
    )
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
    if heatmap:
        lines.append(f"heatmap:     {heatmap}")
    click.echo("\n".join(lines))


def main() -> None:
    """Console-script entry point."""
    catch_signals()
    cli(prog_name="nurbscomp")


if __name__ == "__main__":
    main()
