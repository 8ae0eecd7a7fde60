"""The ``dronewind`` command line.

Each subcommand is a thin shell over a library function, so every workflow step can
also be run and debugged by hand, outside Snakemake.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from dronewind import __version__
from dronewind.errors import DronewindError

EPILOG = """\
examples:
  dronewind validate-campaign config/campaigns/mosai2023.yaml
  dronewind check-cf results/mosai2023/netcdf/L1/s01_sonic.nc
  dronewind show-config config/config.yaml

The whole workflow runs through Snakemake (see README.md):
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
        "--no-files", action="store_true", help="do not check that data files exist (structure and ids only)"
    )


def _validate_campaign(args: argparse.Namespace) -> int:
    from dronewind.manifest import load_campaign

    campaign = load_campaign(args.manifest, check_files=False if args.no_files else None)
    kind = "virtual (simulated)" if campaign.simulated else "measured"
    print(
        f"{campaign.path}: valid {kind} campaign {campaign.name!r}: "
        f"{len(campaign.mast_sonics())} mast sonic(s), {len(campaign.payload_flights)} payload flight(s), "
        f"{len(campaign.quadrotor_flights)} quadrotor flight(s)"
    )
    return 0


def _check_cf_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("files", type=Path, nargs="+", help="NetCDF files")


def _check_cf(args: argparse.Namespace) -> int:
    from dronewind.core.cf import check_compliance

    status = 0
    for path in args.files:
        ok, report = check_compliance(path)
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


def _show_config(args: argparse.Namespace) -> int:
    import yaml

    from dronewind.manifest import with_defaults

    config: dict = {}
    for path in args.configfiles:
        config = _merge(config, yaml.safe_load(path.read_text(encoding="utf-8")) or {})
    print(yaml.safe_dump(with_defaults(config), sort_keys=False), end="")
    return 0


SUBCOMMANDS: list[Subcommand] = [
    Subcommand(
        "validate-campaign",
        "validate a campaign manifest (schema, ids, windows, files)",
        "examples:\n  dronewind validate-campaign config/campaigns/mosai2023.yaml\n"
        "  dronewind validate-campaign --no-files my_campaign.yaml",
        _validate_campaign_args,
        _validate_campaign,
    ),
    Subcommand(
        "check-cf",
        "run the IOOS compliance checker (CF-1.11, ACDD-1.3) on NetCDF files",
        "example:\n  dronewind check-cf results/mosai2023/netcdf/L1/*.nc",
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
    except DronewindError as exc:
        print(f"dronewind {args.command}: error: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
