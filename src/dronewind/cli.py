"""The ``dronewind`` command line.

Each subcommand is a thin shell over a library function, so every workflow step can
also be run and debugged by hand, outside Snakemake.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from dronewind import __version__
from dronewind.errors import DronewindError, InputError

EPILOG = """\
examples:
  dronewind validate-campaign config/campaigns/mosai2023.yaml
  dronewind check-cf results/mosai2023/netcdf/L1/s01_sonic.nc
  dronewind show-config config/config.yaml
  dronewind plan config/plans/example_plan.yaml --out results/plans/example
  dronewind model-error results/*/diagnosis.json

  dronewind run my_campaign.yaml                 # the whole workflow, then the HTML report

`dronewind run` wraps Snakemake (see README.md); the same by hand:
  .venv/bin/snakemake --cores 2 --config campaign=/abs/path/campaign.yaml
"""

@dataclass(frozen=True)
class Subcommand:
    """One ``dronewind`` subcommand: its arguments and the function that runs it."""

    name: str
    help: str
    epilog: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]


def _validate_campaign_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("manifest", type=Path, help="campaign manifest (YAML)")
    parser.add_argument(
        "--no-files", action="store_true",
        help="do not check that data files exist and match their declared formats (structure and ids only)"
    )


def _validate_campaign(args: argparse.Namespace) -> int:
    from dronewind.formats import check_campaign_formats
    from dronewind.manifest import load_campaign

    try:
        campaign = load_campaign(args.manifest, check_files=False if args.no_files else None)
    except UnicodeDecodeError as exc:
        raise InputError(args.manifest, f"not a text (YAML) file: {exc.reason} at byte {exc.start}") from exc
    if not args.no_files:
        # every file's first lines against its declared format (a measured campaign)
        for warning in check_campaign_formats(campaign):
            print(f"warning: {warning}")
    kind = "virtual (simulated)" if campaign.simulated else "measured"
    print(
        f"{campaign.path}: valid {kind} campaign {campaign.name!r}: "
        f"{len(campaign.mast_sonics())} mast sonic(s), {len(campaign.payload_flights)} payload flight(s), "
        f"{len(campaign.quadrotor_flights)} quadrotor flight(s)"
    )
    return 0


def _check_cf_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("files", type=Path, nargs="+", help="NetCDF files")
    parser.add_argument("--plain", action="store_true",
                        help="run the checker as installed, without remembering its whole-file metadata scans for "
                             "each file (the same reports at about 2.2 times the CPU; dronewind.core.compliance)")


def _netcdf_problem(path: Path) -> str | None:
    """Why ``path`` cannot be checked (missing, not a file, not NetCDF), or None."""
    import netCDF4

    if not path.exists():
        return "no such file"
    if not path.is_file():
        return "not a file"
    try:
        with netCDF4.Dataset(path):
            pass
    except OSError as exc:
        return f"not a NetCDF file ({exc.strerror or exc})"
    return None


def _check_cf(args: argparse.Namespace) -> int:
    from dronewind.core.cf import check_compliance_files

    status = 0
    readable = []
    for path in args.files:
        problem = _netcdf_problem(path)
        if problem is not None:
            print(f"dronewind check-cf: error: {path}: {problem}", file=sys.stderr)
            status = 1
        else:
            readable.append(path)
    for path, (ok, report) in check_compliance_files(readable, remember=not args.plain).items():  # one process
        print(f"{path}: {'passes' if ok else 'FAILS'} CF-1.11 and ACDD-1.3 (normal criteria)")
        if not ok:
            print(report)
            status = 1
    return status


def _show_config_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("configfiles", type=Path, nargs="*",
                        help="config files (YAML), later ones override earlier ones; none: the defaults")


def _merge(base: dict, override: dict) -> dict:
    """``base`` updated recursively with ``override`` (as Snakemake merges --configfile files)."""
    out = dict(base)
    for key, value in override.items():
        out[key] = _merge(out[key], value) if isinstance(value, dict) and isinstance(out.get(key), dict) else value
    return out


def _read_config_file(path: Path) -> dict:
    """One config file (YAML mapping); errors name the file and the line."""
    import yaml

    from dronewind.core.yamltext import load_yaml

    if not path.is_file():
        raise InputError(path, "no such file" if not path.exists() else "not a file")
    try:
        data = load_yaml(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        raise InputError(path, f"not a text (YAML) file: {exc.reason}") from exc
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark is not None else str(path)
        raise InputError(where, f"not valid YAML: {getattr(exc, 'problem', None) or exc}") from exc
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise InputError(path, "expected a mapping of settings (processing:, diagnosis:, ...), "
                               f"got {type(data).__name__}")
    return data


def _show_config(args: argparse.Namespace) -> int:
    import yaml

    from dronewind.config import check_config

    config: dict = {}
    for path in args.configfiles:
        config = _merge(config, _read_config_file(path))
    # the same typing and checks as the workflow (a typo is an error naming the nearest key)
    config = check_config({"campaign": "", "results_dir": "", **config})
    for key in ("campaign", "results_dir"):
        if config[key] == "":
            del config[key]
    print(yaml.safe_dump(config, sort_keys=False), end="")
    return 0


def _available_cores() -> int:
    """Cores this process may run on (its CPU affinity where the platform reports it)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on every platform
        return os.cpu_count() or 1


def _plan_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("plan", type=Path, help="plan file (YAML, workflow/schemas/plan.schema.json)")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder for the report page plan.md, plan.json, campaign.yaml and the figures "
                             "(default: results/plans/<plan name>)")
    parser.add_argument("--config", type=Path, action="append", default=[],
                        help="workflow config file(s) whose processing and diagnosis settings the plan uses "
                             "(default: the schema's defaults)")
    parser.add_argument("--no-power", action="store_true",
                        help="uncertainties, separation and manifest only (no simulation of the detection power)")
    parser.add_argument("--workers", type=int, default=_available_cores(),
                        help="processes for the power simulation (default: the cores this process may use, "
                             "here %(default)s); the plan does not depend on it")


def _plan(args: argparse.Namespace) -> int:
    import logging

    from dronewind.config import check_config
    from dronewind.plan import load_plan, plan_campaign
    from dronewind.plan.report import write_plan

    logging.basicConfig(level=logging.INFO, format="%(message)s")  # progress of the power simulation
    spec = load_plan(args.plan)
    config: dict = {}
    for path in args.config:
        config = _merge(config, _read_config_file(path))
    config = check_config({"campaign": "", "results_dir": "", **config}) if args.config else {}
    result = plan_campaign(spec, config, simulate_power=not args.no_power, workers=args.workers)
    out = args.out if args.out is not None else Path("results") / "plans" / spec.name
    files = write_plan(result, out)
    print(result.table())
    print(f"written: {', '.join(str(p) for p in files)}")
    return 0


def _model_error_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("diagnoses", type=Path, nargs="+", help="diagnosis.json files, one per campaign")
    parser.add_argument("--alpha", type=float, default=None,
                        help="family-wise false-alarm rate over the features (default: the unexplained test's, "
                             "0.05)")
    parser.add_argument("--out", type=Path, default=None, help="also write the result as JSON to this file")


def _model_error(args: argparse.Namespace) -> int:
    from dronewind.diagnose.calibration import UNEXPLAINED_ALPHA
    from dronewind.diagnose.pooled import offsets_table, pool_diagnoses, read_campaign
    from dronewind.steps.diagnosis import write_json

    alpha = UNEXPLAINED_ALPHA if args.alpha is None else args.alpha
    if not 0.0 < alpha < 1.0:
        raise InputError("--alpha", f"{alpha:g}: expected a rate between 0 and 1")
    result = pool_diagnoses([read_campaign(p) for p in args.diagnoses], alpha)
    print(offsets_table(result))
    if args.out is not None:
        write_json(args.out, result)
        print(f"written: {args.out}")
    return 0


def _run_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--cores", type=int, default=os.cpu_count() or 1,
                        help="CPU cores Snakemake may use (default: all of this machine's, here %(default)s)")
    parser.add_argument("--no-report", action="store_true",
                        help="do not write the self-contained HTML report after the run")
    parser.add_argument("--report-file", type=Path, default=None,
                        help="the HTML report to write (default: results/<campaign name>/report.html)")
    parser.add_argument("--directory", type=Path, default=None,
                        help="the dronewind project (the folder with the Snakefile; default: the current folder "
                             "if it has one, else the project this dronewind is installed from)")
    parser.add_argument("--show", action="store_true", help="print the Snakemake commands without running them")
    parser.add_argument("campaign",
                        help="campaign manifest (YAML), or the name of one in config/campaigns/ (e.g. mosai2023)")
    parser.add_argument("snakemake_args", nargs=argparse.REMAINDER, metavar="...",
                        help="anything after the campaign goes to Snakemake as it is (e.g. --dry-run, "
                             "--config processing={...}, a target file)")


def _project_dir(given: Path | None) -> Path:
    """The folder with the workflow's Snakefile."""
    candidates = [given] if given is not None else [Path.cwd(), Path(__file__).resolve().parents[2]]
    for folder in candidates:
        if (folder / "Snakefile").is_file():
            return folder.resolve()
    raise InputError(str(candidates[0]), "no Snakefile here: run from the dronewind project or give --directory")


def _campaign_manifest(campaign: str, project: Path) -> Path:
    """The manifest a ``run`` names: a file, or ``config/campaigns/<name>.yaml`` of the project."""
    path = Path(campaign)
    if path.is_file():
        return path.resolve()
    named = project / "config" / "campaigns" / f"{campaign}.yaml"
    if named.is_file():
        return named
    known = sorted(p.stem for p in (project / "config" / "campaigns").glob("*.yaml"))
    raise InputError(campaign, f"no such manifest file, nor a campaign of config/campaigns/ ({', '.join(known)})")


def _snakemake_exe() -> str:
    import shutil

    beside = Path(sys.executable).with_name("snakemake")
    found = str(beside) if beside.is_file() else shutil.which("snakemake")
    if not found:
        raise InputError("snakemake", "the snakemake executable is neither beside this Python nor on PATH "
                         "(make venv installs it)")
    return found


def run_commands(args: argparse.Namespace) -> tuple[Path, list[list[str]]]:
    """The project folder and the Snakemake command lines of ``dronewind run`` (the workflow, then the report)."""
    import yaml

    project = _project_dir(args.directory)
    manifest = _campaign_manifest(args.campaign, project)
    name = (yaml.safe_load(manifest.read_text("utf-8")) or {}).get("name") or manifest.stem
    extra = list(args.snakemake_args)
    if extra[:1] == ["--"]:
        extra = extra[1:]
    exe = _snakemake_exe()
    config = [f"campaign={manifest}"]
    if "--config" in extra:  # one --config option (Snakemake keeps only the last one given)
        at = extra.index("--config") + 1
        while at < len(extra) and not extra[at].startswith("-"):
            config.append(extra.pop(at))
        extra.remove("--config")
    commands = [[exe, "--cores", str(args.cores), *extra, "--config", *config]]
    dry = any(a in ("-n", "--dry-run", "--dryrun") for a in extra)
    if not args.no_report and not dry:
        root = next((c.split("=", 1)[1] for c in config if c.startswith("results_dir=")), "results")
        report = args.report_file if args.report_file is not None else Path(root) / str(name) / "report.html"
        commands.append([exe, "--report", str(report), "--config", *config])
    return project, commands


def _run(args: argparse.Namespace) -> int:
    import shlex
    import subprocess

    project, commands = run_commands(args)
    for cmd in commands:
        print(f"(cd {shlex.quote(str(project))} && {shlex.join(cmd)})", flush=True)
        if args.show:
            continue
        status = subprocess.run(cmd, cwd=project, check=False).returncode
        if status:
            print(f"dronewind run: snakemake stopped with status {status}", file=sys.stderr)
            return status
    if not args.show and len(commands) > 1:
        report = Path(commands[1][2])
        front = project / report.parent / "report" / "summary.html"
        print(f"the answer: {project / report} and its front page {front}")
    return 0


SUBCOMMANDS: list[Subcommand] = [
    Subcommand(
        "run",
        "run the whole workflow on a campaign (Snakemake), then write its self-contained HTML report",
        "examples:\n  dronewind run mosai2023                      # the embedded default campaign\n"
        "  dronewind run /data/my_campaign.yaml --cores 4\n"
        "  dronewind run my_campaign.yaml --dry-run    # what would run (Snakemake's -n)\n"
        "  dronewind run my_campaign.yaml --config \"processing={despike: {n_mad: 5}}\"\n"
        "  dronewind run --show my_campaign.yaml       # print the Snakemake commands only\n\n"
        "Options before the campaign are dronewind's; everything after it goes to Snakemake. The results are\n"
        "in results/<campaign name>/ (front page: report/summary.html; report: report.html).",
        _run_args,
        _run,
    ),
    Subcommand(
        "validate-campaign",
        "validate a campaign manifest (schema, ids, windows, files and their declared formats)",
        "examples:\n  dronewind validate-campaign config/campaigns/mosai2023.yaml\n"
        "  dronewind validate-campaign --no-files my_campaign.yaml",
        _validate_campaign_args,
        _validate_campaign,
    ),
    Subcommand(
        "check-cf",
        "run the IOOS compliance checker (CF-1.11, ACDD-1.3) on NetCDF files",
        "examples:\n  dronewind check-cf results/mosai2023/netcdf/L1/*.nc\n"
        "  dronewind check-cf --plain results/mosai2023/netcdf/L4/s01_drone.nc",
        _check_cf_args,
        _check_cf,
    ),
    Subcommand(
        "show-config",
        "print the effective workflow configuration: config files over the defaults of the config schema",
        "examples:\n  dronewind show-config\n  dronewind show-config config/config.yaml my_settings.yaml",
        _show_config_args,
        _show_config,
    ),
    Subcommand(
        "plan",
        "plan a validation campaign: hover duration, drone-mast separation, number of flights and wind range for "
        "target uncertainties and detection powers, with a report page and a virtual-campaign manifest",
        "examples:\n  dronewind plan config/plans/example_plan.yaml\n"
        "  dronewind plan my_plan.yaml --out results/plans/mine --config config/config.yaml\n"
        "  dronewind plan my_plan.yaml --no-power        # uncertainties, separation and manifest only\n"
        "  dronewind plan my_plan.yaml --workers 1       # the power simulation in this process only\n\n"
        "The plan file: site, conditions (wind_speed_ms at the hover height, wind_from_deg, stability as\n"
        "obukhov_length_m or class, roughness_length_m, boundary_layer_height_m), platform (sling_load,\n"
        "rigid_mount, quadrotor_fleet; max_hover_min), mast (heights_m, hover_height_m, hover_distance_m)\n"
        "and targets (relative_uncertainty per quantity; detect: mechanisms with their sizes; power).\n"
        "Schema: workflow/schemas/plan.schema.json; example: config/plans/example_plan.yaml.\n\n"
        "Cost of the power simulation (2 cores): each error to detect that moves what the chain measures\n"
        "(a heading bias the wind direction, a sonic-INS lag the lag found) needs forward runs of its own.\n"
        "The flights are simulated two at a time, and each error's power drawn up to the first count\n"
        "that reaches the target: up to six 12.5-min flights with one error to detect (a w gain, reached\n"
        "at two flights) take about 30 s; the example's three errors (reached at four flights) about\n"
        "100 s; the three where they need all six flights simulated about 2.5 min.",
        _plan_args,
        _plan,
    ),
    Subcommand(
        "model-error",
        "what the forward model gets wrong on every campaign: each residual feature's mean standardised "
        "residual over several campaigns' diagnoses, tested over the campaigns",
        "examples:\n  dronewind model-error results/*/diagnosis.json\n"
        "  dronewind model-error site_a/diagnosis.json site_b/diagnosis.json --out model_error.json\n\n"
        "One campaign's diagnosis lists a feature as unexplained only where its offset stands above that\n"
        "campaign's few flights; physics the forward model lacks moves the feature alike on every campaign.\n"
        "Per campaign the mean over its flights of (measured - forward baseline) / error is taken, and its mean\n"
        "over the campaigns is tested by a t-test on their spread (Bonferroni over the features). A campaign\n"
        "that was not diagnosed (too few usable flights) is left out and listed.",
        _model_error_args,
        _model_error,
    ),
]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered subcommand."""
    parser = argparse.ArgumentParser(
        prog="dronewind",
        description="Validate drone-borne wind and turbulence measurements against mast sonics.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"dronewind {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for cmd in SUBCOMMANDS:
        sp = sub.add_parser(
            cmd.name,
            help=cmd.help,
            description=cmd.help,
            epilog=cmd.epilog,
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        cmd.add_arguments(sp)
        sp.set_defaults(func=cmd.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``dronewind`` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except (DronewindError, OSError) as exc:
        return _fail(args.command, exc)
    except Exception as exc:  # noqa: BLE001 - one line for the user; the traceback on request
        if os.environ.get("DRONEWIND_DEBUG"):
            raise
        return _fail(args.command, exc, f"{type(exc).__name__}: ", " (DRONEWIND_DEBUG=1 shows the traceback)")


def _fail(command: str, exc: BaseException, prefix: str = "", suffix: str = "") -> int:
    """Print a one-line error of a subcommand to standard error; the exit status (1)."""
    if isinstance(exc, OSError) and exc.filename is not None:
        text = f"{exc.filename}: {exc.strerror or exc}"
    else:
        text = " ".join(str(exc).split())
    print(f"dronewind {command}: error: {prefix}{text}{suffix}", file=sys.stderr)
    return 1

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
