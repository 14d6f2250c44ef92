"""`sfv asi-server`: run the ASI initial-state service until SIGTERM/SIGINT.

    sfv asi-server --port 50061 [--host 127.0.0.1] [--redis-url URL] [--token-file F]
                   [--tls-cert C --tls-key K]

The bearer token comes from --token-file or the SFV_ASI_TOKEN environment variable and is
never logged. Without --redis-url, jobs live in this process and vanish with it.
"""
from __future__ import annotations

import argparse
import logging
import os
import signal
import threading
from pathlib import Path

from learner.errors import SfvError

log = logging.getLogger("sfv.asi_server")


HELP = "run the adaptive state initialization gRPC service"  # the one line `sfv --help` lists (without importing the command)


def register(subparsers) -> None:
    p = subparsers.add_parser("asi-server", help=HELP,
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--port", type=int, required=True, help="port to listen on (0 picks a free one)")
    p.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1)")
    p.add_argument("--redis-url", help="keep jobs in Redis (redis://[:password@]host:port/db) so a restart carries on")
    p.add_argument("--token-file", help="file holding the bearer token clients must send (else $SFV_ASI_TOKEN)")
    p.add_argument("--tls-cert", help="PEM certificate chain for TLS")
    p.add_argument("--tls-key", help="PEM private key for TLS")
    p.add_argument("--max-workers", type=int, default=8, help="request handler threads")
    p.add_argument("--max-jobs", type=int, default=1024, help="most jobs the store accepts")
    p.set_defaults(handler=run)


def read_token(token_file: str | None) -> str | None:
    """Token from the file (surrounding whitespace stripped) or $SFV_ASI_TOKEN; None when neither is set."""
    from services.asi.server import TOKEN_ENV

    if token_file:
        try:
            token = Path(token_file).read_text().strip()
        except OSError as exc:
            raise SfvError(f"{token_file}: cannot read token file ({exc.strerror})") from None
        if not token:
            raise SfvError(f"{token_file}: token file is empty")
        return token
    return os.environ.get(TOKEN_ENV) or None


def run(args: argparse.Namespace) -> int:
    from services.asi.server import serve
    from services.asi.store import InMemoryStore

    if not logging.getLogger().handlers:
        logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    if not 0 <= args.port <= 65535:
        raise SfvError(f"asi-server: --port {args.port} outside 0..65535")
    token = read_token(args.token_file)
    if args.redis_url:
        from services.asi.redis_store import RedisStore

        store = RedisStore(args.redis_url, max_jobs=args.max_jobs)
        log.info("asi jobs in redis at %s", store.safe_url)
    else:
        store = InMemoryStore(max_jobs=args.max_jobs)
    stop = threading.Event()
    for signum in (signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, lambda *_: stop.set())
    server, _ = serve(args.port, store, host=args.host, token=token, tls_cert=args.tls_cert, tls_key=args.tls_key,
                      max_workers=args.max_workers)
    log.info("listening on %s", server.address)
    try:
        # Wake up regularly: a signal delivered to one of gRPC's threads only runs the Python
        # handler once the main thread next executes bytecode, which a bare wait() may never do.
        while not stop.wait(0.25):
            pass
    finally:
        log.info("stopping")
        server.stop(grace=5.0).wait()
        store.close()
    return 0


if __name__ == "__main__":
    # `python -m services.commands.asi_server --port P ...`: the same command without importing
    # every other sub-command (a lighter process for deployments and tests).
    import sys

    parser = argparse.ArgumentParser(prog="sfv")
    register(parser.add_subparsers(dest="command", required=True))
    parsed = parser.parse_args(["asi-server", *sys.argv[1:]])
    try:
        sys.exit(parsed.handler(parsed))
    except SfvError as error:
        print(f"sfv: {error}", file=sys.stderr)
        sys.exit(2)
