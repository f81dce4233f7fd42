#!/usr/bin/env bash
# A throwaway PostgreSQL cluster for the server tests, on a Unix socket only (no TCP port):
#   .ci/postgres.sh start DIR   initdb + start in DIR; prints the tests' URL on stdout
#   .ci/postgres.sh stop DIR    stop it and remove DIR
# The tests read the URL from TURNBENCH_TEST_POSTGRES_URL. As root (CI), the cluster runs as
# the `postgres` user that Debian's package makes (initdb refuses root).
set -euo pipefail
cmd=${1:?start or stop}
dir=${2:?a folder for the cluster}
bindir=$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -n 1)
if [ -z "$bindir" ]; then
    echo "postgres.sh: no PostgreSQL server found (apt-get install postgresql)" >&2
    exit 1
fi
as_owner() {
    if [ "$(id -u)" = 0 ]; then
        su postgres -s /bin/sh -c "$1"
    else
        sh -c "$1"
    fi
}
case "$cmd" in
start)
    mkdir -p "$dir"
    if [ "$(id -u)" = 0 ]; then chown postgres "$dir"; fi
    chmod 700 "$dir"
    as_owner "'$bindir/initdb' -D '$dir/data' -A trust -U postgres -E UTF8 --no-sync >'$dir/initdb.log'"
    as_owner "'$bindir/pg_ctl' -D '$dir/data' -l '$dir/server.log' -w -o \"-k '$dir' -c listen_addresses='' -p 5433 -c fsync=off\" start >/dev/null"
    echo "postgresql+psycopg://postgres@/postgres?host=$dir&port=5433"
    ;;
stop)
    if [ -d "$dir/data" ]; then
        as_owner "'$bindir/pg_ctl' -D '$dir/data' -m fast -w stop >/dev/null" || true
    fi
    rm -rf "$dir"
    ;;
*)
    echo "postgres.sh: start or stop, not $cmd" >&2
    exit 2
    ;;
esac
