#!/usr/bin/env bash
# Installs everything kinemetric needs on a Debian machine, from Debian packages and npm (the
# web page's test tooling, from the committed package-lock.json). Idempotent: installs only
# what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  build-essential cmake ninja-build pkg-config git clang-format ccache
  clang libclang-rt-14-dev lld libboost-dev wrk
  libeigen3-dev libceres-dev libopencv-dev libmodbus-dev libsqlite3-dev sqlite3
  postgresql libpq-dev
  libcpp-httplib-dev nlohmann-json3-dev libssl-dev zlib1g-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcairo2-dev fonts-dejavu-core poppler-utils
  python3 python3-numpy python3-pymodbus python3-serial python3-serial-asyncio
  chromium nodejs npm
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    # node and npm may come from another source on a developer machine; accept them there.
    if { [ "$p" = nodejs ] && command -v node >/dev/null; } || { [ "$p" = npm ] && command -v npm >/dev/null; }; then
      continue
    fi
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -gt 0 ]; then
  echo "install-deps: installing ${missing[*]}"
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "install-deps: Debian packages present"
fi

# npm packages of the web page (browser-test driver), exactly as locked.
if [ -f web/package-lock.json ]; then
  stamp=web/node_modules/.kinemetric-lock-sha
  want=$(sha256sum web/package-lock.json | cut -d' ' -f1)
  if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
    echo "install-deps: npm ci in web/"
    (cd web && npm ci --no-audit --no-fund --loglevel=error)
    echo "$want" > "$stamp"
  fi
fi
