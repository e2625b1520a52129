#!/usr/bin/env bash
# Builds kinemetric (Release) and starts kinemetricd on 127.0.0.1:8080 with its embedded SQLite
# database under ./var/, loading demo data on the first start.
#   KINEMETRIC_LISTEN (default 127.0.0.1:8080), KINEMETRIC_DATA_DIR (default ./var),
#   KINEMETRIC_BOOTSTRAP_TOKEN (default: a token generated once and kept in var/admin-token).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

deploy/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DKINEMETRIC_TESTS=OFF -DKINEMETRIC_BENCHMARKS=OFF >/dev/null
cmake --build build -j"$(nproc)" --target kinemetricd kinemetric

listen=${KINEMETRIC_LISTEN:-127.0.0.1:8080}
data_dir=${KINEMETRIC_DATA_DIR:-$root/var}
mkdir -p "$data_dir"
chmod 700 "$data_dir"
if [ -z "${KINEMETRIC_BOOTSTRAP_TOKEN:-}" ]; then
  if [ ! -s "$data_dir/admin-token" ]; then
    (umask 077; od -An -tx1 -N32 /dev/urandom | tr -d ' \n' > "$data_dir/admin-token")
  fi
  KINEMETRIC_BOOTSTRAP_TOKEN=$(cat "$data_dir/admin-token")
  export KINEMETRIC_BOOTSTRAP_TOKEN
fi

echo
echo "kinemetric dashboard: http://$listen/#token=$KINEMETRIC_BOOTSTRAP_TOKEN"
echo "API token (Authorization: Bearer): $KINEMETRIC_BOOTSTRAP_TOKEN"
echo
exec build/bin/kinemetricd --listen "$listen" --data-dir "$data_dir" --demo-data
