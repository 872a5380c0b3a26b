"""``hitrobot-server token add NAME --role ROLE [--expires 30d|DATE]``, ``token list``,
``token revoke NAME``: the site's named tokens in ``<state-dir>/tokens.json``. A running
server picks a change up within a second, without a restart."""

from __future__ import annotations

import argparse
import datetime as dt
import json
import re
import sys
import time
from pathlib import Path

from ..protocol.access import ROLES, roles_from
from ..state.options import StoreOptions
from ..state.tokens import TokenFileError, add_token, read_table, revoke_token, tokens_path

UNITS = {"s": 1, "m": 60, "h": 3600, "d": 86400, "w": 7 * 86400}
DURATION = re.compile(r"(\d+(?:\.\d+)?)([smhdw])")


def expiry(text: str, now: float) -> float:
    """Seconds since the epoch of ``--expires``: a duration from now (``90m``, ``12h``,
    ``30d``, ``2w``) or an ISO date or time (``2027-01-31``, ``2027-01-31T18:00``, local time
    unless it says its zone)."""
    match = DURATION.fullmatch(text.strip())
    if match:
        return now + float(match.group(1)) * UNITS[match.group(2)]
    try:
        when = dt.datetime.fromisoformat(text.strip())
    except ValueError:
        raise ValueError(f"--expires {text!r}: give a duration (90m, 12h, 30d, 2w) or a date "
                         "(2027-01-31 or 2027-01-31T18:00)") from None
    stamp = when.timestamp()
    if stamp <= now:
        raise ValueError(f"--expires {text!r} is in the past")
    return stamp


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hitrobot-server token",
        description="Named tokens for --authenticate: each has a role; only its hash is kept "
        "(in STATE_DIR/tokens.json). The running server sees changes within a second.")
    parser.add_argument("--state-dir", help="the server's --state-dir (default: "
                        "$XDG_STATE_HOME/hitrobot-server)")
    parser.add_argument("--roles", help="the server's --roles file, for roles it adds")
    sub = parser.add_subparsers(dest="action", required=True)
    add = sub.add_parser("add", help="make a token for NAME and print it once")
    add.add_argument("name")
    add.add_argument("--role", required=True, help="the token's role: monitor, viewer, "
                     "operator, admin, agent, or one of the --roles file")
    add.add_argument("--expires", help="a duration (90m, 12h, 30d, 2w) or a date")
    sub.add_parser("list", help="the tokens' names, roles, creation and expiry (no secrets)")
    revoke = sub.add_parser("revoke", help="remove NAME's token")
    revoke.add_argument("name")
    for each in sub.choices.values():  # also after the action: token list --state-dir D
        each.add_argument("--state-dir", dest="sub_state_dir", help=argparse.SUPPRESS)
        each.add_argument("--roles", dest="sub_roles", help=argparse.SUPPRESS)
    return parser


def main(argv: list[str]) -> int:
    args = _parser().parse_args(argv)
    path = tokens_path(StoreOptions(state_dir=args.sub_state_dir or args.state_dir).state_root)
    try:
        return _run(args, path)
    except TokenFileError as exc:
        print(f"hitrobot-server token: the tokens file is damaged: {exc}\n"
              f"(the server keeps using its last good table; fix or remove {path})",
              file=sys.stderr)
        return 1
    except (OSError, ValueError) as exc:
        print(f"hitrobot-server token: {exc}", file=sys.stderr)
        return 1


def _run(args: argparse.Namespace, path: Path) -> int:
    now = time.time()
    if args.action == "add":
        file = args.sub_roles or args.roles
        roles = roles_from(Path(file).read_text(encoding="utf-8")).roles if file else ROLES
        if args.role not in roles:
            raise ValueError(f"--role {args.role!r}: known roles are {', '.join(roles)}")
        if not args.name.strip() or len(args.name) > 100:
            raise ValueError("NAME must be 1 to 100 characters")
        expires = expiry(args.expires, now) if args.expires else None
        token = add_token(path, args.name, args.role, expires, now)
        print(token)
        print(f"token for {args.name!r} ({args.role}) saved in {path}; it is shown only now",
              file=sys.stderr)
        return 0
    if args.action == "revoke":
        if not revoke_token(path, args.name):
            print(f"hitrobot-server token: no token named {args.name!r}", file=sys.stderr)
            return 1
        print(f"revoked {args.name!r}", file=sys.stderr)
        return 0
    for record in read_table(path).values():
        shown = record.public()
        shown["expired"] = record.expires is not None and record.expires <= now
        print(json.dumps(shown))
    return 0
