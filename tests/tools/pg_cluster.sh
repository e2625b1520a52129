#!/bin/sh
# A private PostgreSQL 15 cluster for tests: initdb into a directory, a server listening on
# 127.0.0.1 only, on a free port, trust authentication for loopback, fsync off (test data only).
#
#   pg_cluster.sh start DIR [--watch PID]
#                              prints one line: postgresql://kinemetric@127.0.0.1:PORT/postgres;
#                              with --watch, the cluster is stopped and removed once process PID
#                              has ended (a test that crashed leaves no server behind)
#   pg_cluster.sh stop DIR     stops the server (fast) and removes the cluster and DIR
#   pg_cluster.sh pause DIR    stops the server, keeps the cluster (an outage)
#   pg_cluster.sh resume DIR   starts it again on the same port
#   pg_cluster.sh restart DIR  pg_ctl restart (fast)
#
# PostgreSQL refuses to run as root: run as root, the cluster belongs to an unprivileged user
# (postgres when it exists, else nobody), and lives in a directory under /tmp when DIR is not
# reachable by that user (DIR then records where: DIR/cluster_dir).
set -eu

BIN=${KINEMETRIC_PG_BIN:-/usr/lib/postgresql/15/bin}
SUPERUSER=kinemetric

usage() {
  echo "usage: pg_cluster.sh start|stop|pause|resume|restart DIR [--watch PID]" >&2
  exit 2
}

[ $# -eq 2 ] || [ $# -eq 4 ] || usage
cmd=$1
dir=$2
watch_pid=""
if [ $# -eq 4 ]; then
  [ "$cmd" = start ] && [ "$3" = --watch ] || usage
  watch_pid=$4
fi
script=$(cd "$(dirname "$0")" && pwd)/$(basename "$0")
case $dir in /*) ;; *) dir=$(pwd)/$dir ;; esac
cd /tmp

runas=""
if [ "$(id -u)" -eq 0 ]; then
  if id postgres >/dev/null 2>&1; then runas=postgres; else runas=nobody; fi
fi

# Runs a command as the cluster's owner.
as_owner() {
  if [ -n "$runas" ]; then runuser -u "$runas" -- "$@"; else "$@"; fi
}

cluster_dir() {
  if [ -f "$dir/cluster_dir" ]; then cat "$dir/cluster_dir"; else echo "$dir/cluster"; fi
}

free_port() {
  /usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

start_server() {
  data=$1
  port=$2
  as_owner "$BIN/pg_ctl" -D "$data" -l "$data/server.log" -w -t 30 -s \
    -o "-p $port -k $data -c listen_addresses=127.0.0.1" start >/dev/null
}

start() {
  mkdir -p "$dir"
  data="$dir/cluster"
  if [ -n "$runas" ]; then
    chown "$runas" "$dir"
    if ! runuser -u "$runas" -- test -w "$dir" -a -x "$dir"; then
      data=$(mktemp -d /tmp/kinemetric-pg.XXXXXX)
      chown "$runas" "$data"
      echo "$data" >"$dir/cluster_dir"
    fi
  fi
  as_owner "$BIN/initdb" -D "$data" -U "$SUPERUSER" -A trust -E UTF8 --locale=C --no-sync \
    >"$dir/initdb.log" 2>&1 || {
    cat "$dir/initdb.log" >&2
    exit 1
  }
  cat >>"$data/postgresql.conf" <<EOF
listen_addresses = '127.0.0.1'
fsync = off
synchronous_commit = off
full_page_writes = off
max_connections = 300
shared_buffers = 32MB
EOF
  tries=0
  while :; do
    port=$(free_port)
    if start_server "$data" "$port"; then break; fi
    tries=$((tries + 1))
    if [ $tries -ge 5 ]; then
      cat "$data/server.log" >&2
      exit 1
    fi
  done
  echo "$port" >"$dir/port"
  if [ -n "$watch_pid" ]; then
    (
      while [ -d "/proc/$watch_pid" ]; do sleep 1; done
      sh "$script" stop "$dir"
    ) </dev/null >/dev/null 2>&1 &
  fi
  echo "postgresql://$SUPERUSER@127.0.0.1:$port/postgres"
}

case "$cmd" in
  start) start ;;
  stop)
    data=$(cluster_dir)
    if [ -f "$data/postmaster.pid" ]; then
      as_owner "$BIN/pg_ctl" -D "$data" -m fast -w -s stop >/dev/null 2>&1 || true
    fi
    rm -rf "$data" "$dir"
    ;;
  pause) as_owner "$BIN/pg_ctl" -D "$(cluster_dir)" -m fast -w -s stop >/dev/null ;;
  resume) start_server "$(cluster_dir)" "$(cat "$dir/port")" ;;
  restart)
    data=$(cluster_dir)
    as_owner "$BIN/pg_ctl" -D "$data" -l "$data/server.log" -m fast -w -s restart >/dev/null
    ;;
  *) usage ;;
esac
