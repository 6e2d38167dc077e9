#!/usr/bin/env bash
# Installs the Debian packages named on the command line that are not installed yet.
# As root: apt-get update (once) and apt-get install. Otherwise: print the command and fail,
# so that `make` stops with a message a person can act on.
set -euo pipefail
missing=()
for package in "$@"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" -eq 0 ]; then
  echo "servokit: installing Debian packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "servokit: missing Debian packages: ${missing[*]}" >&2
  echo "servokit: run: sudo apt-get install -y ${missing[*]}" >&2
  exit 1
fi
