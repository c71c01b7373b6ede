"""The command line.  The only module that prints or exits.

Exit codes (``errors.EXIT_*``): 0 ok; 1 bad input file; 2 usage; 3 output
exists or cannot be written; 4 damaged container; 5 verification failed;
6 ``eval`` found the reconstruction failing its verdict; 70 internal error;
128 + the signal's number when interrupted (130 SIGINT, 129 SIGHUP, 143
SIGTERM).  A batch exits with the highest code among its files.  Errors are
one line, ``error: FILE: message``, on stderr; ``--debug`` adds the
traceback.  README, "Exit codes and errors", lists every error class.

gzip's, xz's and zstd's habits hold where they do not clash with the verbs:
``nurbscomp -d FILE`` decompresses, ``-t`` tests, ``-l`` lists, ``-z``
compresses (:class:`_Group`); ``-k`` is accepted (inputs are always kept) and
``--rm`` removes them.
"""

from __future__ import annotations

import json
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import click

from . import __version__, signals
from .errors import EXIT_DIFFERS, EXIT_USAGE
from .units import DEFAULT_TOL_MM, TOL_RANGE_MM, check_tolerance, parse_length


class _Length(click.ParamType):
    name = "LENGTH"

    def convert(self, value: Any, param: Any, ctx: Any) -> float:
        if isinstance(value, float):
            return value
        try:
            return parse_length(str(value))
        except ValueError as e:
            self.fail(str(e), param, ctx)


class _Tolerance(_Length):
    """A length ``compress`` can code to (``units.TOL_RANGE_MM``)."""

    def convert(self, value: Any, param: Any, ctx: Any) -> float:
        try:
            return check_tolerance(super().convert(value, param, ctx))
        except ValueError as e:
            self.fail(str(e), param, ctx)


class _State:
    def __init__(self, debug: bool) -> None:
        self.debug = debug
        self.exit_code = 0


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
    signum = signals.signum_of(e)
    made = sys.modules.get("nurbscomp.paths")  # loaded by whatever wrote an output
    if made is not None:
        made.remove_leftovers()
    for path in names or ["batch"]:
        click.echo(f"error: {show(path)}: {signals.describe(signum)}", err=True)
    sys.exit(128 + signum)


def _run(state: _State, path: str, fn: Callable[[], dict[str, Any]]) -> dict[str, Any] | None:
    """Run one file's work; turn any failure into one ``error:`` line
    (``batch.failure``'s classes and exit codes); None then."""
    from .batch import failure

    try:
        return fn()
    except KeyboardInterrupt as e:
        _interrupted(e, [path])
    except Exception as e:  # reported by its class: an OCCT or internal failure too
        try:
            r = failure(e, state.debug)
        except KeyboardInterrupt as stop:  # the failure was the interrupt's doing
            _interrupted(stop, [path])
    if r.get("traceback"):
        click.echo(r["traceback"].rstrip("\n"), err=True)
    click.echo(f"error: {show(path)}: {show(r['error'])}", err=True)
    state.exit_code = max(state.exit_code, r["exit_code"])
    return None


#: Plurals that are not the noun and an ``s``.
_PLURALS = {"vertex": "vertices", "assembly": "assemblies"}
_SINGULARS = {v: k for k, v in _PLURALS.items()}


def _plural(n: int, word: str) -> str:
    """``1 face``, ``2 faces``: a count with its noun in the number it takes."""
    return f"{n} {word if n == 1 else _PLURALS.get(word, word + 's')}"


def _by_kind(c: dict[str, int]) -> str:
    """Counts by kind, kind first (``plane 60, bspline_surface 6``): no noun to inflect."""
    return ", ".join(f"{k} {v}" for k, v in c.items())


def _geometry_counts(g: dict[str, int]) -> str:
    """``info``'s geometry line: ``3 surfaces, 3 3-D curves, 1 2-D curve``."""
    names = {"surfaces": "surface", "curves3d": "3-D curve", "curves2d": "2-D curve"}
    return ", ".join(_plural(n, names.get(k, k)) for k, n in g.items())


def _fmt_counts(c: dict[str, int]) -> str:
    """Counts keyed by plural or singular nouns (``faces`` or ``face``), with
    each noun in the number its count takes."""
    out = []
    for k, v in c.items():
        word = _SINGULARS.get(k, k[:-1] if k.endswith("s") else k)
        out.append(_plural(v, word))
    return ", ".join(out)


#: gzip's operation modes, short and long, and the command each stands for.
_MODES = {
    "-z": "compress",
    "--compress": "compress",
    "-d": "decompress",
    "--decompress": "decompress",
    "--uncompress": "decompress",
    "-t": "test",
    "--test": "test",
    "-l": "info",
    "--list": "info",
}
#: Short options that take no value: they may be grouped with a mode (``-dk``, ``-tv``).
_FLAG_LETTERS = set("zdtlkfcrqv")
#: The group's own options, which stay before the command a mode puts in.
_GROUP_OPTIONS = ("--debug", "-V", "--version")


def _modes_to_command(args: list[str], commands: Any) -> list[str]:
    """``-d FILE`` -> ``decompress FILE`` (and ``-z``, ``-t``, ``-l``), as gzip,
    xz and zstd take them, anywhere before ``--``; grouped short flags are
    split (``-dkf`` -> ``decompress -kf``).

    Raises
    ------
    click.UsageError
        Two modes, or a mode and another command (``compress -d DIR``, the
        output folder's old short option, says so).
    """
    modes: list[tuple[str, str]] = []
    rest: list[str] = []
    for i, a in enumerate(args):
        if a == "--":
            rest += args[i:]
            break
        if a in _MODES:
            modes.append((a, _MODES[a]))
            continue
        if (
            a.startswith("-")
            and not a.startswith("--")
            and len(a) > 2
            and set(a[1:]) <= _FLAG_LETTERS
        ):
            found = [c for c in a[1:] if f"-{c}" in _MODES]
            modes += [(f"-{c}", _MODES[f"-{c}"]) for c in found]
            others = "".join(c for c in a[1:] if f"-{c}" not in _MODES)
            if others:
                rest.append(f"-{others}")
            continue
        rest.append(a)
    if not modes:
        return args
    flag, mode = modes[0]
    other = next((f for f, m in modes if m != mode), None)
    if other is not None:
        raise click.UsageError(f"{flag} and {other} exclude each other")
    i = 0
    while i < len(rest) and rest[i] in _GROUP_OPTIONS:
        i += 1
    named = rest[i] if i < len(rest) else None
    if named in commands:
        if named != mode:
            hint = " (the output folder is -O/--output-dir)" if flag == "-d" else ""
            raise click.UsageError(f"{flag} means {mode}; it cannot go with {named}{hint}")
        return rest
    return [*rest[:i], mode, *rest[i:]]


class _Group(click.Group):
    """The command group, taking gzip's mode flags for commands (:func:`_modes_to_command`)."""

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        return super().parse_args(ctx, _modes_to_command(list(args), self.commands))


def _mode_flag(short: str, long: str, what: str) -> Callable[[Any], Any]:
    """A mode flag in ``--help``; :class:`_Group` turns it into its command first."""
    return click.option(short, long, is_flag=True, expose_value=False, help=what)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, "-V", "--version", prog_name="nurbscomp")
@click.option("--debug", is_flag=True, help="Show the traceback of each error.")
@_mode_flag("-z", "--compress", "Compress: the same as the compress command.")
@_mode_flag("-d", "--decompress", "Decompress (also --uncompress): nurbscomp -d FILE.nzc.")
@_mode_flag("-t", "--test", "Test containers: the same as the test command.")
@_mode_flag("-l", "--list", "List what containers hold: the same as the info command.")
@click.pass_context
def cli(ctx: click.Context, debug: bool) -> None:
    """Compress STEP and IGES B-reps into .nzc containers, and back to STEP.

    \b
    Examples:
      nurbscomp compress part.step            # -> part.step.nzc (tol 0.01 mm)
      nurbscomp compress --lossless *.stp     # the same bytes back (SHA-256)
      nurbscomp decompress part.step.nzc      # -> part.step
      nurbscomp -d part.step.nzc              # the same, as gzip -d
      nurbscomp decompress a.nzc -o a.igs     # IGES (or .brep) by extension
      nurbscomp info part.step.nzc --json     # or nurbscomp -l *.nzc
      nurbscomp test -r archive/ -j 2         # or nurbscomp -t *.nzc
      nurbscomp eval part.step part.step.nzc  # deviation and a verdict
    \b
    Batches, pipes:
      nurbscomp compress -r parts/ -O archive/ -j 4 --json > report.jsonl
      nurbscomp compress -r parts/ -O archive/ --skip-existing   # resume
      nurbscomp decompress -r archive/ -O back/                  # mirror the tree
      nurbscomp compress -r parts/ -O archive/ --scheduler tcp://host:8786
      cat part.step | nurbscomp compress - -c > part.nzc
      nurbscomp decompress -c part.nzc | head   # in the source's format

    \b
    Exit codes: 0 ok; 1 bad input file; 2 bad usage; 3 output exists or
    cannot be written; 4 damaged container (or past the decoding limits);
    5 verification failed; 6 eval: the reconstruction fails its verdict;
    70 internal error; a batch exits with the highest code among its files.
    130 interrupted (Ctrl-C), 143 terminated (SIGTERM), 129 hung up (SIGHUP).
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


def _options(f: Any, opts: list[Any]) -> Any:
    for opt in reversed(opts):
        f = opt(f)
    return f


_RECURSIVE = click.option("-r", "--recursive", is_flag=True, help="Walk folders given as inputs.")
_JOBS = click.option(
    "-j",
    "--jobs",
    type=click.IntRange(min=0),
    default=0,
    help="Worker processes (default 0: one per core; 1: no workers).",
)
_JSON = click.option(
    "--json",
    "as_json",
    is_flag=True,
    help="One JSON line per file, failures included, then a summary line.",
)
_QUIET = click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")
_KEEP = click.option(
    "-k",
    "--keep",
    is_flag=True,
    expose_value=False,
    help="Keep the inputs: always so (accepted for gzip's habit; --rm removes them).",
)


def _batch_options(verbose_help: str) -> Callable[[Any], Any]:
    """The options every file-converting command shares, like xz and zstd."""

    def wrap(f: Any) -> Any:
        return _options(
            f,
            [
                click.option(
                    "-o", "--output", type=click.Path(), help="Output file (one input; -: stdout)."
                ),
                click.option(
                    "-O",
                    "--output-dir",
                    type=click.Path(file_okay=False),
                    help="Write outputs here, mirroring the folders walked by -r.",
                ),
                _RECURSIVE,
                click.option("-c", "--stdout", "to_stdout", is_flag=True, help="Write to stdout."),
                _JOBS,
                click.option(
                    "--scheduler",
                    metavar="tcp://HOST:PORT",
                    help="Run the files on this Dask cluster (sent as bytes).",
                ),
                click.option("-f", "--force", is_flag=True, help="Overwrite existing outputs."),
                click.option(
                    "--skip-existing", is_flag=True, help="Skip files whose output exists (resume)."
                ),
                _KEEP,
                click.option(
                    "--rm",
                    "remove_input",
                    is_flag=True,
                    help="Remove each input once its output is written (and verified, by "
                    "compress).",
                ),
                _JSON,
                _QUIET,
                click.option("-v", "--verbose", is_flag=True, help=verbose_help),
            ],
        )

    return wrap


def _sizes(a: int, b: int) -> str:
    """``A -> B`` bytes in one unit, chosen by the larger (bytes, kB or MB),
    each to three significant digits: ``0.862 MB -> 0.0219 MB``."""
    big = max(a, b)
    unit, div = ("MB", 1e6) if big >= 10**6 else ("kB", 1e3) if big >= 10**4 else ("bytes", 1.0)

    def num(x: float) -> str:
        return str(int(x)) if div == 1 else f"{x:.0f}" if x >= 1000 else f"{x:.3g}"

    return f"{num(a / div)} {unit} -> {num(b / div)} {unit}"


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
                f"{_sizes(self.bytes_in, self.bytes_out)}, {self.bytes_in / self.bytes_out:.1f}x",
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
    json_summary: bool = True,
) -> None:
    """Plan the tasks, run them (here, in workers or on a cluster), print a line
    per file and a summary; exit with the highest code among the files.  On an
    interrupt, the files whose outputs were renamed into place count as done,
    in the lines and the summary, and the exit status is 128 + the signal."""
    from . import batch

    as_json, quiet = kw["as_json"], kw["quiet"]
    try:
        tasks = batch.plan(
            list(files),
            opts,
            recursive=kw["recursive"],
            output=kw.get("output"),
            output_dir=kw.get("output_dir"),
            to_stdout=kw.get("to_stdout", False),
        )
    except batch.UsageError as e:
        raise click.UsageError(str(e)) from None
    to_stdout = any(t.dst is None for t in tasks) and opts.command not in batch.CHECKS
    binary = opts.command == "compress" or opts.fmt == "BREP"
    if to_stdout and sys.stdout.isatty() and binary:
        raise click.UsageError("refusing to write binary data to a terminal (redirect, or -o)")
    if any(t.src == batch.STDIO for t in tasks) and sys.stdin.isatty():
        raise click.UsageError("refusing to read data from a terminal (pipe a file into -)")
    jobs = kw["jobs"] or batch.cores()
    show_bar = not quiet and len(tasks) > 0 and sys.stderr.isatty()
    bar = _Bar(len(tasks), show_bar)
    runner = batch.Runner(
        tasks,
        opts,
        jobs,
        kw.get("scheduler"),
        read_stdin=lambda: sys.stdin.buffer.read(),
        stage=bar.stage if show_bar else None,
    )
    say_err = to_stdout  # the data owns stdout
    records: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    gen = runner.records()
    stop: KeyboardInterrupt | None = None

    # the default tolerance is said once, with the first file it was used on
    lossless = opts.lossless or opts.exact
    untold = opts.command == "compress" and kw.get("tol") is None and not lossless
    untold = untold and not (quiet or as_json)

    shown: set[tuple[str, str | None]] = set()  # (input, output) of each record printed

    def report(r: dict[str, Any], count: bool = True) -> None:
        nonlocal untold
        if count:
            records.append(r)
            bar.update(r)
        if untold and r["status"] == "ok" and r.get("mode") == "tolerance":
            bar.write(f"tolerance {opts.tol:g} mm (default; --tol to change)", True)
            untold = False
        _report(state, r, as_json, quiet, text, bar, say_err)
        shown.add((r["input"], r["output"]))

    try:
        for r, blob in gen:
            if blob is not None:
                sys.stdout.buffer.write(blob)
                sys.stdout.buffer.flush()
            report(r)
    except KeyboardInterrupt as e:
        stop = e
        gen.close()  # stops the workers: each removes the output it was writing
        counted = {(r["input"], r["output"]) for r in records}
        for r in runner.settled():  # what was done but not printed, once
            if (r["input"], r["output"]) not in shown:
                report(r, count=(r["input"], r["output"]) not in counted)
    except batch.SchedulerError as e:
        bar.close()
        click.echo(f"error: {show(kw['scheduler'])}: {show(e)}", err=True)
        sys.exit(1)
    finally:
        gen.close()
        bar.close()
    s = batch.summary(records, time.perf_counter() - t0)
    if stop is not None:
        s["interrupted"] = True
        s["exit_code"] = 128 + signals.signum_of(stop)
    if as_json:
        if json_summary or stop is not None:
            click.echo(json.dumps(s, sort_keys=True), err=say_err)
    elif not quiet and (len(records) > 1 or stop is not None):
        click.echo(_summary_text(s), err=say_err)
    if stop is not None:
        _interrupted(stop, runner.running)
    sys.exit(s["exit_code"])


def _summary_text(s: dict[str, Any]) -> str:
    """The batch's summary line."""
    from .batch import CHECKS  # loaded already: the batch ran

    counts = f"{_plural(s['files'], 'file')}: {s['ok']} ok"
    if s["passthrough"]:
        counts += f" ({s['passthrough']} stored verbatim)"
    counts += f", {s['failed']} failed"
    if s["skipped"]:
        counts += f", {s['skipped']} skipped"
    if s.get("interrupted"):
        counts += ", then interrupted"
    if s["command"] in CHECKS or not s["bytes_in"]:
        return f"{counts}; {s['seconds']:.1f} s"
    ratio = f", {s['ratio']:.1f}x" if s["ratio"] else ""
    return f"{counts}; {_sizes(s['bytes_in'], s['bytes_out'])}{ratio}; {s['seconds']:.1f} s"


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
@click.option(
    "--lossless",
    is_flag=True,
    help="Give back the same file, byte for byte (SHA-256 checked); no OpenCASCADE needed.",
)
@click.option(
    "--lossless-brep",
    is_flag=True,
    help="Keep every number of the B-rep bit for bit: the same shape back, as a new file.",
)
@click.option(
    "--tol",
    type=_Tolerance(),
    default=None,
    help=f"Tolerance, mm unless suffixed (um, in, mil...), from {TOL_RANGE_MM[0]:g} to "
    f"{TOL_RANGE_MM[1]:g} mm. Default {DEFAULT_TOL_MM} mm.",
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
    lossless_brep: bool,
    tol: float | None,
    no_verify: bool,
    step_safe: bool,
    verbose: bool,
    **kw: Any,
) -> None:
    """Compress STEP/IGES FILES to FILE.nzc (the input is kept).

    FILES may be folders (with -r) and - (standard input, to standard output
    unless -o).  Three modes: a tolerance (--tol, the default 0.01 mm: every
    face within it, certified), --lossless (the same file back, byte for
    byte), --lossless-brep (the same B-rep back, every number bit for bit).
    A valid STEP/IGES file that holds no B-rep (tessellated, curves only) is
    stored byte for byte, with a warning.
    """
    from .batch import Options

    if lossless and lossless_brep:
        raise click.UsageError("--lossless and --lossless-brep exclude each other")
    if (lossless or lossless_brep) and tol is not None:
        flag = "--lossless" if lossless else "--lossless-brep"
        raise click.UsageError(f"{flag} and --tol exclude each other")
    opts = Options(
        "compress",
        force=kw["force"],
        skip_existing=kw["skip_existing"],
        tol=None if lossless or lossless_brep else (tol if tol is not None else DEFAULT_TOL_MM),
        lossless=lossless_brep,
        exact=lossless,
        verify=not no_verify,
        step_safe=step_safe,
        debug=state.debug,
        remove_input=kw["remove_input"],
    )
    _batch(state, files, opts, {**kw, "tol": tol}, lambda r: _compress_text(r, verbose))


def _compress_text(r: dict[str, Any], verbose: bool) -> str:
    if r.get("interrupted"):
        return f"{r['input']} -> {r['output']}: done before the interrupt"
    if r["mode"] in ("passthrough", "exact"):
        how = "stored verbatim" if r["mode"] == "passthrough" else "lossless, byte-exact"
        return (
            f"{r['input']} -> {r['output']}: {r['input_bytes']} -> {r['output_bytes']} bytes "
            f"({r['ratio']:.1f}x, {how}, {r['seconds']:.2f} s"
            f"{', verified' if r['verified'] else ''})"
        )
    mode = "lossless B-rep" if r["mode"] == "lossless" else f"tol {r['tolerance_mm']:g} mm"
    line = (
        f"{r['input']} -> {r['output']}: {r['input_bytes']} -> {r['output_bytes']} bytes "
        f"({r['ratio']:.1f}x, {mode}, {r['seconds']:.2f} s"
        f"{', verified' if r['verified'] else ''})"
    )
    if verbose:
        line += f"\n  {_fmt_counts(r['counts'])}; unit {r['unit']}; faces by type: "
        line += _by_kind(r["faces_by_type"])
        if r["faces_by_method"]:
            line += "\n  faces by method: "
            line += _by_kind(dict(sorted(r["faces_by_method"].items())))
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
    help="Output format (default: by -o's extension; with -c, the source's; else STEP).",
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
        remove_input=kw["remove_input"],
    )

    def text(r: dict[str, Any]) -> str:
        if r.get("interrupted"):
            return f"{r['input']} -> {r['output']}: done before the interrupt"
        if r.get("passthrough") or r.get("exact"):
            return f"{r['input']} -> {r['output']}: {r['format']}, the exact bytes"
        line = f"{r['input']} -> {r['output']}: {r['format']} in {r['unit']}"
        line += f", {r['seconds']:.2f} s"
        return line + (f"\n  {_fmt_counts(r['counts'])}" if verbose else "")

    _batch(state, files, opts, kw, text)


@cli.command()
@click.argument("files", nargs=-1, required=True, type=click.Path())
@_RECURSIVE
@click.option("--json", "as_json", is_flag=True, help="One JSON line per file, failures included.")
@_QUIET
@_limit_scale
@click.pass_obj
def info(state: _State, files: tuple[str, ...], **kw: Any) -> None:
    """Show what .nzc FILES hold (like xz -l): version, mode, unit, counts,
    bytes per section, product.  FILES may be folders (with -r)."""
    from .batch import Options

    opts = Options("info", debug=state.debug, limit_scale=kw.pop("limit_scale"))
    first = True

    def text(r: dict[str, Any]) -> str:
        nonlocal first
        lines = "\n".join(_info_lines(r))
        lines, first = (lines if first else "\n" + lines), False
        return lines

    _batch(state, files, opts, {**kw, "jobs": 1}, text, json_summary=False)


def _info_lines(r: dict[str, Any]) -> list[str]:
    """``info``'s text for one container."""
    head = [
        f"file:        {r['input']} ({r['file_bytes']} bytes)",
        f"format:      .nzc {r['format_version']}, body coded with {r['coder']}",
    ]
    if r["mode"] in ("passthrough", "exact"):
        what = (
            f"passthrough (the file stored verbatim: {r['reason']})"
            if r.get("passthrough")
            else "lossless, byte-exact (the file itself)"
        )
        return [
            *head,
            f"mode:        {what}",
            f"source:      {r['source_name']} ({r['source_format']}, {r['source_bytes']} bytes)",
            f"sha256:      {r['sha256']}",
            f"text model:  {r['model']}",
            f"ratio:       {r['source_bytes'] / r['file_bytes']:.1f}x",
        ]
    mode = "lossless B-rep" if r["mode"] == "lossless" else f"tolerance {r['tolerance_mm']:g} mm"
    return [
        *head,
        f"mode:        {mode}",
        f"source:      {r['source_name']} ({r['source_format']}, "
        f"{r['source_bytes']} bytes, unit {r['unit']})",
        f"ratio:       {r['source_bytes'] / r['file_bytes']:.1f}x",
        f"shapes:      {_fmt_counts(r['shapes'])}",
        *([] if r.get("step_pcurves", True) else ["STEP output: no pcurves, as in the source"]),
        *(
            []
            if r.get("uncertainty") is None
            else [f"STEP/IGES output: uncertainty {r['uncertainty']:g} mm"]
        ),
        f"faces:       {_by_kind(r['faces_by_type'])}",
        f"geometry:    {_geometry_counts(r['geometry'])}",
        "sections:    "
        + ", ".join(f"{k} {v}" for k, v in r["section_raw_bytes"].items())
        + f" bytes raw; {r['body_stored_bytes']} bytes coded",
        *_product_lines(r.get("product")),
    ]


def _product_lines(p: dict[str, Any] | None) -> list[str]:
    """``info``'s product summary (format 1.2), or a line saying there is none."""
    if p is None:
        return ["product:     none stored (a format 1.0/1.1 container, or none in the source)"]
    coloured = ", ".join(_plural(v, k) for k, v in p["coloured"].items()) or "nothing"
    counts = _fmt_counts({k: p[k] for k in ("parts", "assemblies", "instances")})
    return [
        f"product:     {counts}, depth {p['depth']}, {_plural(p['named'], 'name')}",
        f"colours:     {_plural(p['colours'], 'colour')} on {coloured}",
        f"layers:      {p['layers']}",
        f"schema:      {', '.join(p['schema']) or '-'}",
        f"dropped:     {'; '.join(p['dropped']) or 'nothing'}",
    ]


@cli.command("test")
@click.argument("files", nargs=-1, required=True, type=click.Path())
@_RECURSIVE
@_JOBS
@_JSON
@_QUIET
@_KEEP
@_limit_scale
@click.pass_obj
def test_cmd(state: _State, files: tuple[str, ...], **kw: Any) -> None:
    """Check .nzc FILES (like xz -t): checksums, references, the decoding
    limits, and a full rebuild.  FILES may be folders (with -r) and -
    (standard input)."""
    from .batch import Options

    opts = Options("test", debug=state.debug, limit_scale=kw.pop("limit_scale"))

    def text(r: dict[str, Any]) -> str:
        if r.get("exact") or r.get("passthrough"):
            return f"{r['input']}: OK (the exact file, sha256 {r['sha256'][:16]}...)"
        return f"{r['input']}: OK ({_plural(r['faces'], 'face')})"

    _batch(state, files, opts, kw, text)


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
    help="Tolerance to hold the deviation to, and to mark on the heatmap (default: the "
    "container's if RECONSTRUCTED is one, 0 for a lossless one; else no deviation check).",
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
    """Compare two CAD files (STEP, IGES or .nzc): deviation, topology,
    validity, free edges, and a verdict.

    Faces are paired by index; points sampled inside each ORIGINAL face are
    measured against the RECONSTRUCTED face of the same index.  The verdict
    passes when the deviation is within the tolerance, the topology counts are
    the same, the reconstruction is valid wherever the original is, and it
    has no more free edges; otherwise eval exits 6.  --heatmap renders the
    RECONSTRUCTED model offscreen with a colour bar in mm, the tolerance
    marked and the worst face on its own.
    """
    from . import pipeline

    r = _run(
        state,
        reconstructed,
        lambda: pipeline.evaluate(original, reconstructed, tol=tol, heatmap=heatmap, force=force),
    )
    if r is None:
        sys.exit(state.exit_code)
    code = 0 if r["verdict"] == "pass" else EXIT_DIFFERS
    if as_json:
        click.echo(json.dumps({**r, "exit_code": code}, sort_keys=True))
        sys.exit(code)
    fe = r["free_edges"]
    if r["tolerance_mm"] is None:
        given = "none (--tol to check the deviation)"
    else:
        given = f"{r['tolerance_mm']:g} mm" + (" (the container's)" if tol is None else "")
    lines = [
        f"tolerance:   {given}",
        f"topology:    {_fmt_counts(r['counts']['original'])}",
        f"             {_fmt_counts(r['counts']['reconstructed'])}"
        + ("" if r["topology_same"] else "  (differs)"),
        f"valid:       {r['valid']['original']} -> {r['valid']['reconstructed']}",
        f"free edges:  {fe['original']} -> {fe['reconstructed']}",
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
    lines.append(f"verdict:     {_verdict_text(r)}")
    click.echo("\n".join(show(line) for line in lines))
    sys.exit(code)


def _verdict_text(r: dict[str, Any]) -> str:
    """``eval``'s verdict line: ``pass: ...`` or ``FAIL: ...``, each check named."""
    fe = r["free_edges"]
    said: dict[str, dict[bool | None, str]] = {
        "within_tolerance": {
            True: f"within {r['tolerance_mm']:g} mm",
            False: f"deviation {r.get('max_deviation_mm', 0):.3g} mm beyond "
            f"{r['tolerance_mm'] or 0:g} mm",
            None: "deviation not checked",
        },
        "topology_same": {True: "same topology", False: "topology differs"},
        "valid_kept": {
            True: "valid" if r["valid"]["reconstructed"] else "invalid as the original",
            False: "invalid where the original is valid",
        },
        "free_edges_kept": {
            True: "no new free edges",
            False: f"{fe['reconstructed']} free edges where the original has {fe['original']}",
        },
    }
    words = ", ".join(said[k][r[k]] for k in said)
    return f"pass: {words}" if r["verdict"] == "pass" else f"FAIL: {words}"


def main() -> None:
    """Console-script entry point: handles the stop signals
    (``signals.install``), and prints a usage error under ``--json`` as one
    JSON line too."""
    signals.install()
    try:
        cli.main(prog_name="nurbscomp", standalone_mode=False)
    except click.UsageError as e:
        if "--json" in sys.argv[1:]:
            err = {"status": "failed", "error_class": "UsageError", "error": e.format_message()}
            click.echo(json.dumps({**err, "exit_code": EXIT_USAGE}, sort_keys=True))
        e.show()
        sys.exit(EXIT_USAGE)
    except click.ClickException as e:
        e.show()
        sys.exit(e.exit_code)
    except click.Abort:  # click turns an interrupt in its own code into Abort
        _interrupted(KeyboardInterrupt(), [])
    except KeyboardInterrupt as e:
        _interrupted(e, [])


if __name__ == "__main__":
    main()
