#!/usr/bin/env bash
# The database of a test server. Without KINEMETRIC_TEST_DATABASE nothing is printed: the server
# keeps its embedded SQLite file in its data directory. With KINEMETRIC_TEST_DATABASE set to a
# PostgreSQL server (postgresql://USER@HOST:PORT, e.g. from tests/tools/pg_cluster.sh), the
# database of DATA_DIR (named after the directory's path, so a restarted server finds its data
# again) is created when missing, and its URL is printed: pass it as --database URL.
#   test_database.sh DATA_DIR
set -euo pipefail
[ -n "${KINEMETRIC_TEST_DATABASE:-}" ] || exit 0
dir=$(realpath -m "$1")
server=${KINEMETRIC_TEST_DATABASE%/}
server=${server%/postgres}
name="km_$(printf '%s' "$dir" | sha1sum | cut -c1-20)"
export PGCONNECT_TIMEOUT=10
if ! psql -qtA -d "$server/postgres" -c "SELECT 1 FROM pg_database WHERE datname = '$name'" |
  grep -q 1; then
  # Two servers of one test may ask at once: an existing database is fine.
  psql -q -d "$server/postgres" -c "CREATE DATABASE $name" >/dev/null 2>&1 ||
    psql -qtA -d "$server/postgres" -c "SELECT 1 FROM pg_database WHERE datname = '$name'" |
    grep -q 1
fi
echo "$server/$name"
