"""``eomc cache [info|prune|clear]``: what the build cache holds, and taking space back.

    eomc cache                       where it is, entries per kind, total size
    eomc cache info --list           ... and every entry, least recently used first
    eomc cache prune --max-size 500M drop least recently used entries down to 500 MiB
    eomc cache prune --older-than 30d
    eomc cache clear                 remove everything

New builds prune automatically past $EOMC_CACHE_MAX_SIZE (default 2G, 0: never).
"""
import time

from eomc.compiler.build.cache import cache_root
from eomc.compiler.build.cache_admin import (clear, format_size, max_size_from_env, parse_age, parse_size,
                                prune, usage)

__all__ = ["configure", "run"]


def configure(parser):
    parser.add_argument("action", nargs="?", default="info", choices=("info", "prune", "clear"),
                        help="info (default), prune or clear")
    parser.add_argument("--cache-dir", default=None,
                        help="cache location (default: $EOMC_CACHE_DIR or ~/.cache/eomc)")
    parser.add_argument("--list", action="store_true", help="info: list every entry")
    parser.add_argument("--max-size", default=None, metavar="SIZE",
                        help="prune: keep at most SIZE (e.g. 500M, 2G), least recently used go first")
    parser.add_argument("--older-than", default=None, metavar="AGE",
                        help="prune: remove entries unused for AGE (e.g. 30d, 12h)")
    parser.add_argument("--dry-run", action="store_true", help="prune: only say what would go")
    parser.add_argument("-q", "--quiet", action="store_true", help="prune/clear: print nothing on success")


def _age(seconds):
    for unit, size in (("d", 86400), ("h", 3600), ("min", 60)):
        if seconds >= size:
            return f"{seconds / size:.0f} {unit}"
    return f"{seconds:.0f} s"


def _info(root, show_list):
    u = usage(root)
    limit = max_size_from_env()
    print(f"cache: {root}")
    print(f"size: {format_size(u['total'])} "
          f"(automatic pruning above {format_size(limit) if limit else 'never'})")
    for kind, (count, size) in sorted(u["by_kind"].items()):
        print(f"  {kind:<10} {count:>5} entries  {format_size(size):>10}")
    if u["failed"]:
        print(f"  {'failed':<10} {'':>5}          {format_size(u['failed']):>10}  "
              f"(sources of failed compiles, kept for you to read)")
    if show_list and u["entries"]:
        now = time.time()
        print(f"\n{'last used':>12}  {'size':>10}  {'kind':<10} {'name':<24} key")
        for e in u["entries"]:
            print(f"{_age(now - e.last_used) + ' ago':>12}  {format_size(e.size):>10}  "
                  f"{e.kind:<10} {e.name or '-':<24} {e.key[:16]}")


def run(args):
    root = cache_root(args.cache_dir)
    if args.action == "info":
        _info(root, args.list)
        return 0
    if args.action == "clear":
        freed = clear(root)
        if not args.quiet:
            print(f"cleared {root}: {format_size(freed)} freed")
        return 0
    if args.max_size is None and args.older_than is None:
        raise ValueError("eomc cache prune needs --max-size SIZE and/or --older-than AGE")
    max_size = parse_size(args.max_size) if args.max_size is not None else None
    older = parse_age(args.older_than) if args.older_than is not None else None
    removed = prune(root, max_size=max_size, older_than=older, dry_run=args.dry_run)
    verb = "would remove" if args.dry_run else "removed"
    if args.quiet and not args.dry_run:
        return 0
    print(f"{verb} {len(removed)} entries, {format_size(sum(e.size for e in removed))}; "
          f"{format_size(usage(root)['total'])} in the cache now")
    return 0
