"""synthcompose: insert 3D objects into Cityscapes image sets with differential rendering and write
new, fully annotated image sets. Commands: batch, make-sample, compare-lighting, preview,
check-placement, report (``synthcompose COMMAND -h`` for each)."""
from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from .errors import SynthComposeError


def _batch(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from synthcompose.run.batch import run_batch

    from .manifest import load_manifest

    manifest = load_manifest(args.manifest)
    if args.output:
        manifest = replace(manifest, output=Path(args.output).resolve())
    if args.limit is not None:
        manifest = replace(manifest, limit=args.limit)
    progress = None if not args.no_progress else False
    use_ray = args.ray is not None
    summary = run_batch(manifest, workers=args.workers, progress=progress, use_ray=use_ray,
                        ray_address=args.ray or None, gpus=args.gpus, gpus_per_actor=args.ray_gpus,
                        resume=not args.no_resume)
    print(summary.text())
    print(f"outputs: {manifest.output}")
    return summary.exit_code


def _make_sample(args: argparse.Namespace) -> int:
    from .synthetic import make_sample

    width, height = args.size
    ids = make_sample(Path(args.out), count=args.count, width=width, height=height, seed=args.seed,
                      stereo=args.stereo, photo=args.photo, right=not args.no_right, light=args.light,
                      streets=None if args.streets == "plain" else args.streets)
    print(f"wrote {len(ids)} image sets to {args.out}")
    return 0


def _finished_batch(out: str) -> Path:
    """The output root of a finished batch, or an error naming it (never created here)."""
    root = Path(out)
    if not root.is_dir():
        raise SynthComposeError(f"{root}: no such output root (give the output folder of a finished batch)")
    return root


def _check_placement(args: argparse.Namespace) -> int:
    from synthcompose.tools.check import check_output, format_table

    _finished_batch(args.out)

    results = check_output(Path(args.out))
    print(format_table(results))
    print(f"written: {Path(args.out) / 'placement_check.json'}")
    return 1 if args.strict and any(r.failures for r in results) else 0


def _report(args: argparse.Namespace) -> int:
    from synthcompose.tools.report import write_report

    _finished_batch(args.out)
    print(f"written: {write_report(Path(args.out))}")
    return 0


def _compare_lighting(args: argparse.Namespace) -> int:
    from synthcompose.tools.compare import compare_lighting

    from .manifest import load_manifest
    from .record import Status

    results = compare_lighting(load_manifest(args.manifest), Path(args.out), limit=args.limit)
    for r in results:
        print(f"{r['image_set']}: {r['status']}" + "".join(f"\n  {p}" for p in r["written"]))
    return 0 if all(r["status"] in (Status.DONE, Status.NO_PLACEMENT) for r in results) else 1


# --- preview (preview/)
def _preview(args: argparse.Namespace) -> int:
    from .manifest import load_manifest

    manifest = load_manifest(args.manifest)
    if args.export_ply:  # headless: no window, no windowing toolkit imported
        from synthcompose.preview.session import PreviewSession

        session = PreviewSession(manifest, args.frame)
        try:
            session.load()
            info = session.export_ply(args.export_ply, args.colour)
            for line in session.legend():
                print(line)
        finally:
            session.close()
        print(f"written: {args.export_ply} ({info['points']} points, {info['objects']} object boxes)")
        return 0
    from synthcompose.preview.window import run_preview

    return run_preview(manifest, args.frame)
# --- end preview


def _count(minimum: int):
    """argparse type: an integer of at least ``minimum`` (a clear refusal otherwise)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"{value} is below {minimum}")
        return value
    return parse


#: make-sample's image sizes: each side within these pixels, and at most this many pixels (the
#: generator holds a few dozen float arrays of the frame: 16 Mpx takes ~2.5 GB; Cityscapes is 2 Mpx)
SAMPLE_SIDE = (64, 8192)
SAMPLE_PIXELS = 16 << 20


def _size(text: str) -> tuple[int, int]:
    """argparse type: ``WIDTHxHEIGHT`` in pixels, each side and the area within the limits above."""
    parts = text.strip().lower().replace("\u00d7", "x").split("x")
    if len(parts) != 2 or not all(p.strip().isascii() and p.strip().isdigit() for p in parts):
        raise argparse.ArgumentTypeError(f"{text!r} is not WIDTHxHEIGHT (two whole numbers, e.g. 2048x1024)")
    width, height = (int(p) for p in parts)
    lo, hi = SAMPLE_SIDE
    if not (lo <= width <= hi and lo // 2 <= height <= hi):
        raise argparse.ArgumentTypeError(f"{width}x{height}: the width must be {lo} to {hi} pixels and the height "
                                         f"{lo // 2} to {hi}")
    if width * height > SAMPLE_PIXELS:
        raise argparse.ArgumentTypeError(f"{width}x{height} is {width * height} pixels, more than the {SAMPLE_PIXELS} "
                                         "a sample may have (Cityscapes' frames have 2097152)")
    return width, height


def _share(text: str) -> float:
    """argparse type: a finite number of at least 0 (GPUs per Ray actor)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0 <= value <= 1e6:
        raise argparse.ArgumentTypeError(f"{text} is not a number from 0 up")
    return value


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    common = argparse.ArgumentParser(add_help=False)  # -v before or after the command
    common.add_argument("-v", "--verbose", action="store_true", default=argparse.SUPPRESS, help="debug logging")
    parser = argparse.ArgumentParser(prog="synthcompose", description=__doc__, parents=[common])
    parser.add_argument("--version", action="version", version=f"synthcompose {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    def command(name: str, **kw) -> argparse.ArgumentParser:
        return sub.add_parser(name, parents=[common], **kw)

    b = command("batch", help="augment every image set a manifest selects")
    b.add_argument("manifest", help="manifest JSON (see README)")
    b.add_argument("--output", help="override the manifest's output root")
    b.add_argument("--limit", type=_count(1), help="process at most this many image sets (1 or more)")
    b.add_argument("--no-progress", action="store_true", help="plain log lines instead of a progress bar")
    b.add_argument("--workers", type=_count(0), default=1,
                   help="worker processes, each with its own GL context; 0 = one per core; more than the cores "
                        "and the memory (about 1 GiB each) allow are capped, with a message (with --ray: actors; "
                        "0 = one per Ray CPU)")
    b.add_argument("--gpus", type=_count(0), default=0, help="spread local workers over this many GPUs (EGL devices)")
    b.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS",
                   help="run as Ray actors: on a local Ray instance, or the cluster at ADDRESS "
                        "(needs pip install 'synthcompose[ray]')")
    b.add_argument("--ray-gpus", type=_share, default=0.0, help="GPUs per Ray actor (default 0)")
    b.add_argument("--no-resume", action="store_true", help="redo image sets an earlier run completed")
    b.set_defaults(func=_batch)
    s = command("make-sample", help="generate synthetic image sets in Cityscapes format")
    s.add_argument("out", help="Cityscapes root to write")
    s.add_argument("--count", type=_count(1), default=3)
    s.add_argument("--size", type=_size, default=(2048, 1024), metavar="WIDTHxHEIGHT",
                   help=f"pixels (default 2048x1024; sides {SAMPLE_SIDE[0]} to {SAMPLE_SIDE[1]}, "
                        f"at most {SAMPLE_PIXELS >> 20} Mpx)")
    s.add_argument("--seed", type=_count(0), default=0)
    s.add_argument("--stereo", choices=("realistic", "exact"), default="realistic",
                   help="disparity as semi-global matching measures it (default) or the exact one")
    s.add_argument("--photo", choices=("realistic", "clean"), default="realistic",
                   help="the photo as Cityscapes' camera records it (default) or the clean shading")
    s.add_argument("--no-right", action="store_true", help="write no right view (rightImg8bit) of the stereo pair")
    s.add_argument("--light", choices=("default", "sunny"), default="default",
                   help="an overcast day's shading (default) or a sunny day's: a sun with cast shadows")
    s.add_argument("--streets", choices=("plain", "traffic"), default="plain",
                   help="plain: the street as earlier versions drew it (default); traffic: streets laid out as "
                        "traffic uses them (two-way, one-way, parking bays, zebra crossings), one kind per frame")
    s.set_defaults(func=_make_sample)
    cl = command("compare-lighting", help="side by side: fixed light | estimated light, input | output")
    cl.add_argument("manifest", help="manifest JSON (see README)")
    cl.add_argument("out", help="folder for the comparison PNGs (and both full outputs)")
    cl.add_argument("--limit", type=_count(1), help="at most this many image sets (1 or more)")
    cl.set_defaults(func=_compare_lighting)
    pv = command("preview", help="a window to debug placement (needs pip install 'synthcompose[preview]')")
    pv.add_argument("manifest", help="manifest JSON (see README)")
    pv.add_argument("--frame", help="start at this image set (city_seq_frame)")
    pv.add_argument("--export-ply", metavar="FILE", help="write the frame's point cloud and object boxes as PLY "
                                                          "and exit (headless, no window)")
    pv.add_argument("--colour", choices=("rgb", "label"), default="rgb", help="point colours in the PLY")
    pv.set_defaults(func=_preview)
    c = command("check-placement", help="measure the placements of a finished batch")
    c.add_argument("out", help="output root of a batch")
    c.add_argument("--strict", action="store_true", help="exit 1 when any object is outside the limits")
    c.set_defaults(func=_check_placement)
    r = command("report", help="write a static HTML page about a finished batch")
    r.add_argument("out", help="output root of a batch")
    r.set_defaults(func=_report)
    return parser


#: the exit status of a run stopped by Ctrl-C (SIGINT) or SIGTERM alike: 128 + SIGINT, the
#: shell's status for Ctrl-C; one status for both, so that a script tests one number
INTERRUPTED = 130


def _stop_on_sigterm(signum, frame) -> None:
    """SIGTERM stops a run as Ctrl-C does: the same unwinding (workers told to stop, the lock
    released, no partial file left under a final name), the same line, the same status."""
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if getattr(args, "verbose", False) else logging.INFO,
                        format="%(levelname)s %(message)s", stream=sys.stderr)
    import signal
    import threading

    main_thread = threading.current_thread() is threading.main_thread()
    before = signal.signal(signal.SIGTERM, _stop_on_sigterm) if main_thread else None
    try:
        return args.func(args)
    except SynthComposeError as exc:
        print(f"synthcompose: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM: one line, no traceback; a rerun resumes
        print("synthcompose: interrupted (a rerun resumes where this one stopped)", file=sys.stderr)
        return INTERRUPTED
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, before)


if __name__ == "__main__":
    sys.exit(main())
