#!/usr/bin/env bash
# Run Redis and the sfv ASI server on the head node of a `ray up` cluster.
#
#   start-asi-and-redis.sh start|stop|restart|status
#
# Both bind the head's private address (never 0.0.0.0), so only cluster nodes reach them:
# Redis with `requirepass`, the ASI server with bearer-token auth. On success it writes
# $SFV_STATE_DIR/endpoints.env (SFV_ASI_ADDRESS, SFV_REDIS_HOST, SFV_REDIS_PORT) for jobs
# whose driver runs on the head.
#
# Environment (loaded from $SFV_STATE_DIR/secrets.env when not already set):
#   SFV_REDIS_PASSWORD  Redis password; URL-safe (e.g. `openssl rand -hex 32`)
#   SFV_ASI_TOKEN       bearer token the ASI server demands
# Optional:
#   SFV_BIND_HOST   address to bind (default: this node's first IPv4 from `hostname -I`)
#   SFV_REDIS_PORT  default 6379          SFV_ASI_PORT  default 50051
#   SFV_STATE_DIR   default ~/.sfv (config, logs, pid files, Redis data)
#   SFV_BIN         sfv executable (default: `sfv` on PATH, else ~/sfv-venv/bin/sfv)
set -euo pipefail

STATE_DIR="${SFV_STATE_DIR:-$HOME/.sfv}"
REDIS_PORT="${SFV_REDIS_PORT:-6379}"
ASI_PORT="${SFV_ASI_PORT:-50051}"
REDIS_CONF="$STATE_DIR/redis.conf"
REDIS_PID="$STATE_DIR/redis.pid"
ASI_PID="$STATE_DIR/asi-server.pid"
ASI_LOG="$STATE_DIR/asi-server.log"
ENDPOINTS="$STATE_DIR/endpoints.env"
STARTUP_TIMEOUT_S=30

die() {
    echo "start-asi-and-redis: $*" >&2
    exit 2
}

load_secrets() {
    if [[ -z "${SFV_REDIS_PASSWORD:-}" || -z "${SFV_ASI_TOKEN:-}" ]] && [[ -f "$STATE_DIR/secrets.env" ]]; then
        set -a
        # shellcheck disable=SC1091
        . "$STATE_DIR/secrets.env"
        set +a
    fi
    [[ -n "${SFV_REDIS_PASSWORD:-}" ]] || die "SFV_REDIS_PASSWORD is not set (nor in $STATE_DIR/secrets.env)"
    [[ -n "${SFV_ASI_TOKEN:-}" ]] || die "SFV_ASI_TOKEN is not set (nor in $STATE_DIR/secrets.env)"
    # The password goes into a redis:// URL; reject characters that would need escaping.
    [[ "$SFV_REDIS_PASSWORD" =~ ^[A-Za-z0-9._~-]+$ ]] \
        || die "SFV_REDIS_PASSWORD must be URL-safe ([A-Za-z0-9._~-]); use: openssl rand -hex 32"
    export SFV_ASI_TOKEN
}

bind_host() {
    local host="${SFV_BIND_HOST:-}"
    if [[ -z "$host" ]]; then
        host="$(hostname -I 2>/dev/null | awk '{print $1}')"
    fi
    [[ -n "$host" ]] || die "cannot tell this node's private address; set SFV_BIND_HOST"
    [[ "$host" != "0.0.0.0" ]] || die "SFV_BIND_HOST=0.0.0.0 would expose Redis and ASI on every interface"
    echo "$host"
}

sfv_bin() {
    if [[ -n "${SFV_BIN:-}" ]]; then
        echo "$SFV_BIN"
    elif command -v sfv > /dev/null; then
        command -v sfv
    elif [[ -x "$HOME/sfv-venv/bin/sfv" ]]; then
        echo "$HOME/sfv-venv/bin/sfv"
    else
        die "sfv not found on PATH nor at ~/sfv-venv/bin/sfv; set SFV_BIN"
    fi
}

# pid from FILE if that process is alive and its command line contains WORD, else nothing
# (a stale pid file whose number was reused by another process is not ours to signal).
live_pid() {
    local file="$1" word="$2" pid
    [[ -f "$file" ]] || return 1
    pid="$(cat "$file")"
    [[ "$pid" =~ ^[0-9]+$ ]] && kill -0 "$pid" 2> /dev/null \
        && tr '\0' ' ' < "/proc/$pid/cmdline" | grep -q -- "$word" && echo "$pid"
}

redis_ping() {
    REDISCLI_AUTH="$SFV_REDIS_PASSWORD" redis-cli --no-auth-warning -h "$1" -p "$REDIS_PORT" ping 2> /dev/null | grep -q PONG
}

start_redis() {
    local host="$1" deadline
    if live_pid "$REDIS_PID" redis-server > /dev/null; then
        echo "redis already running (pid $(cat "$REDIS_PID"))"
        return
    fi
    command -v redis-server > /dev/null || die "redis-server not installed (apt-get install redis-server)"
    mkdir -p "$STATE_DIR/redis"
    # The config holds the password: create it readable by this user only.
    (
        umask 077
        cat > "$REDIS_CONF" << EOF
bind $host
port $REDIS_PORT
protected-mode yes
requirepass $SFV_REDIS_PASSWORD
appendonly yes
dir $STATE_DIR/redis
daemonize yes
pidfile $REDIS_PID
logfile $STATE_DIR/redis.log
EOF
    )
    redis-server "$REDIS_CONF"
    deadline=$((SECONDS + STARTUP_TIMEOUT_S))
    until redis_ping "$host"; do
        ((SECONDS < deadline)) || die "redis did not answer on $host:$REDIS_PORT within ${STARTUP_TIMEOUT_S}s; see $STATE_DIR/redis.log"
        sleep 0.5
    done
    echo "redis listening on $host:$REDIS_PORT"
}

asi_healthy() {
    # grpc.health.v1 Check; the server answers it without a token.
    "$1" - "$2" << 'EOF'
import sys

import grpc
from grpc_health.v1 import health_pb2, health_pb2_grpc

with grpc.insecure_channel(sys.argv[1]) as channel:
    try:
        reply = health_pb2_grpc.HealthStub(channel).Check(health_pb2.HealthCheckRequest(), timeout=2)
    except grpc.RpcError:
        sys.exit(1)
sys.exit(0 if reply.status == health_pb2.HealthCheckResponse.SERVING else 1)
EOF
}

start_asi() {
    local host="$1" sfv python pid deadline
    if live_pid "$ASI_PID" asi-server > /dev/null; then
        echo "asi-server already running (pid $(cat "$ASI_PID"))"
        return
    fi
    sfv="$(sfv_bin)"
    python="$(dirname "$sfv")/python"
    [[ -x "$python" ]] || python="python3"
    # setsid + nohup: keep serving after the `ray up` SSH session that started it ends.
    # The token reaches the server through SFV_ASI_TOKEN (exported), not argv.
    setsid nohup "$sfv" asi-server --host "$host" --port "$ASI_PORT" \
        --redis-url "redis://:${SFV_REDIS_PASSWORD}@${host}:${REDIS_PORT}/0" \
        > "$ASI_LOG" 2>&1 < /dev/null &
    pid=$!
    echo "$pid" > "$ASI_PID"
    deadline=$((SECONDS + STARTUP_TIMEOUT_S))
    until asi_healthy "$python" "$host:$ASI_PORT"; do
        if ! kill -0 "$pid" 2> /dev/null; then
            rm -f "$ASI_PID"
            tail -n 20 "$ASI_LOG" >&2 || true
            die "asi-server exited during startup; log: $ASI_LOG"
        fi
        ((SECONDS < deadline)) || die "asi-server not SERVING on $host:$ASI_PORT within ${STARTUP_TIMEOUT_S}s; log: $ASI_LOG"
        sleep 0.5
    done
    echo "asi-server listening on $host:$ASI_PORT (pid $pid)"
}

# Send TERM to the process in FILE and wait for it to go (Redis flushes its AOF on TERM).
stop_pidfile() {
    local name="$1" file="$2" pid deadline
    if ! pid="$(live_pid "$file" "$name")"; then
        rm -f "$file"
        echo "$name not running"
        return
    fi
    kill -TERM "$pid"
    deadline=$((SECONDS + STARTUP_TIMEOUT_S))
    while kill -0 "$pid" 2> /dev/null; do
        ((SECONDS < deadline)) || die "$name (pid $pid) still running ${STARTUP_TIMEOUT_S}s after SIGTERM"
        sleep 0.2
    done
    rm -f "$file"
    echo "$name stopped"
}

status() {
    local pid rc=0
    if pid="$(live_pid "$REDIS_PID" redis-server)"; then echo "redis running (pid $pid)"; else echo "redis not running"; rc=3; fi
    if pid="$(live_pid "$ASI_PID" asi-server)"; then echo "asi-server running (pid $pid)"; else echo "asi-server not running"; rc=3; fi
    [[ -f "$ENDPOINTS" ]] && cat "$ENDPOINTS"
    return "$rc"
}

start() {
    local host
    load_secrets
    host="$(bind_host)"
    mkdir -p "$STATE_DIR"
    chmod 700 "$STATE_DIR"
    start_redis "$host"
    start_asi "$host"
    printf 'SFV_ASI_ADDRESS=%s:%s\nSFV_REDIS_HOST=%s\nSFV_REDIS_PORT=%s\n' \
        "$host" "$ASI_PORT" "$host" "$REDIS_PORT" > "$ENDPOINTS"
}

stop() {
    stop_pidfile asi-server "$ASI_PID"
    stop_pidfile redis-server "$REDIS_PID"
    rm -f "$ENDPOINTS"
}

case "${1:-}" in
    start) start ;;
    stop) stop ;;
    restart) stop && start ;;
    status) status ;;
    *)
        echo "usage: $0 start|stop|restart|status" >&2
        exit 2
        ;;
esac
