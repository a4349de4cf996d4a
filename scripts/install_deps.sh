#!/usr/bin/env bash
# Installs the Debian 12 packages topo_gaussian needs (ROS 1 from Debian, PCL, OpenCV, Eigen, ...).
# The list is package.xml's: every <*depend> key is resolved through rosdep/topo_gaussian.yaml (the
# rosdep rules of this package) to its Debian packages, so the manifest is the only list.
# Idempotent: installs only what is missing; does nothing (and needs no network) when all is there.
#   scripts/install_deps.sh           install what is missing
#   scripts/install_deps.sh --check   the rosdep-check equivalent: exit 1 naming every key that does not
#                                     resolve and every package that is not installed; installs nothing
#   scripts/install_deps.sh --list    print "KEY: PACKAGE ..." for every key and exit
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
MANIFEST="${TOPO_MANIFEST:-$ROOT/package.xml}"  # overridable for the tests
RULES="${TOPO_ROSDEP_RULES:-$ROOT/rosdep/topo_gaussian.yaml}"
MODE="${1:-install}"
case "$MODE" in install | --check | --list) ;; *)
  echo "[install_deps] unknown option '$MODE': use no option, --check or --list" >&2
  exit 2
  ;;
esac

# Keys: the text of every <buildtool_depend>, <depend>, <build_depend>, <exec_depend>, <test_depend>, ...
# outside comments, in order, once each.
mapfile -t KEYS < <(sed -e 's/<!--.*-->//g' "$MANIFEST" |
  sed -n 's/^[[:space:]]*<\([a-z_]*depend\)>[[:space:]]*\([^<[:space:]]*\)[[:space:]]*<\/\1>.*/\2/p' | awk '!seen[$0]++')
if [ ${#KEYS[@]} -eq 0 ]; then
  echo "[install_deps] $MANIFEST declares no dependencies: is it the package manifest?" >&2
  exit 1
fi

# Rules: "KEY:" then "  debian: [a, b]".
declare -A RULE
while IFS=$'\t' read -r key pkgs; do RULE["$key"]="$pkgs"; done < <(awk '
  /^[A-Za-z0-9_.+-]+:[[:space:]]*$/ { key = $0; sub(/:[[:space:]]*$/, "", key); next }
  /^[[:space:]]+debian:[[:space:]]*\[/ { line = $0; sub(/^[^\[]*\[/, "", line); sub(/\].*$/, "", line);
                                          gsub(/,/, " ", line); gsub(/[[:space:]]+/, " ", line);
                                          print key "\t" line }' "$RULES")

PACKAGES=()
unresolved=()
for k in "${KEYS[@]}"; do
  if [ -z "${RULE[$k]:-}" ]; then unresolved+=("$k"); continue; fi
  read -r -a pk <<<"${RULE[$k]}"
  [ "$MODE" = --list ] && echo "$k: ${pk[*]}"
  PACKAGES+=("${pk[@]}")
done
[ "$MODE" = --list ] && exit 0
if [ ${#unresolved[@]} -ne 0 ]; then
  echo "[install_deps] package.xml keys without a rule in rosdep/topo_gaussian.yaml: ${unresolved[*]}" >&2
  echo "[install_deps] fix: add each as \"KEY:\" and \"  debian: [PACKAGE]\" to rosdep/topo_gaussian.yaml" >&2
  exit 1
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ "$MODE" = --check ]; then
  if [ ${#missing[@]} -eq 0 ]; then
    echo "[install_deps] all ${#KEYS[@]} keys of package.xml resolve; their ${#PACKAGES[@]} packages are installed"
    exit 0
  fi
  echo "[install_deps] not installed: ${missing[*]} (run scripts/install_deps.sh)" >&2
  exit 1
fi

if [ ${#missing[@]} -eq 0 ]; then
  echo "[install_deps] all ${#PACKAGES[@]} packages of package.xml's ${#KEYS[@]} keys already installed"
  exit 0
fi

echo "[install_deps] installing ${#missing[@]} missing packages: ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "[install_deps] not root and no sudo: install as root: ${missing[*]}" >&2; exit 1; }
  SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
echo "[install_deps] done"
