"""``python -m squish.distributed SCENE.toml -o OUT [--address auto] [--chunk N]``: a shot's frames
as Ray tasks (see ``squish.distributed``). Exit codes as ``squish run``: 0 every frame done, 1 some
chunks failed twice (listed with their error), 2 bad input, 130 stopped by Ctrl-C."""

from __future__ import annotations

import argparse
import sys

import squish
from squish.distributed import run_shot


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m squish.distributed",
        description="Run a scene's frames as Ray tasks; the files are those of `squish run`, byte for byte.",
    )
    parser.add_argument("scene", help="the scene file (TOML; docs/scene-format.md)")
    parser.add_argument("-o", "--output", help="output folder (default: the scene's output.dir)")
    parser.add_argument(
        "--address",
        default=None,
        help='Ray cluster: "auto" (a node of a running cluster), "ray://HEAD:10001" (Ray Client); '
        "default: a local Ray instance",
    )
    parser.add_argument("--chunk", type=int, default=8, help="frames per task (default 8)")
    parser.add_argument("--threads-per-task", type=int, default=1, help="worker threads (and CPUs) per task")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    try:
        output = args.output
        if output is None:
            output, _ = squish.Scene.load(args.scene).output
        run = run_shot(
            args.scene,
            output,
            address=args.address,
            chunk=args.chunk,
            threads_per_task=args.threads_per_task,
            progress=not args.no_progress,
        )
    except squish.InputError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted: the report lists the frames done; run the same command again to finish", file=sys.stderr)
        return 130
    for failure in run.failed:
        frame = f" (frame {failure['failed_frame']})" if failure["failed_frame"] is not None else ""
        print(f"error: frames {failure['frames']}{frame} failed twice: {failure['error']}", file=sys.stderr)
    for object, missing in run.incomplete.items():
        print(f"error: the parts of {object} miss frames {', '.join(missing)}", file=sys.stderr)
    for file in run.files:
        print(f"merged the parts of the shot into {file}")
    summary = run.report.get("summary", {})
    print(
        f"{len(run.computed)} frames computed, {len(run.skipped)} already done; "
        f"missing: {', '.join(run.report.get('missing_frames', [])) or 'none'}; "
        f"max |dV/V| {((summary.get('max_volume_change') or {}).get('value') or 0):.1e}; report: {run.report_path}"
    )
    return 0 if run.complete else 1


if __name__ == "__main__":
    sys.exit(main())
