#!/usr/bin/env bash
# Set up rdmesh on Debian 12 (system packages, a virtual environment, the
# package itself) and run one job. Idempotent: a second run only redoes what
# changed.
#
#   bash scripts/quickstart.sh demo    # mesh a built-in surface, write mesh + picture
#   bash scripts/quickstart.sh test    # run the test suite
#   bash scripts/quickstart.sh bench   # run the benchmark against CGAL
#   bash scripts/quickstart.sh docs    # build the documentation site into docs/_build/html
#
# Environment: RDMESH_VENV (default .venv), PYTHON (default python3).
set -euo pipefail
cd "$(dirname "$0")/.."

job="${1:-demo}"
shift || true
venv="${RDMESH_VENV:-.venv}"
python="${PYTHON:-python3}"

say() { printf 'quickstart: %s\n' "$*" >&2; }

# 1. System packages (CGAL 5.5 headers, a C++ compiler, CMake, Python venv; for
#    the documentation, graphviz's `dot` draws the pipeline diagram).
packages=(g++ cmake make libcgal-dev libgmp-dev libmpfr-dev python3-venv python3-dev)
if [[ "$job" == docs ]]; then
  packages+=(graphviz)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  say "installing ${missing[*]}"
  if [[ $(id -u) -ne 0 ]]; then
    say "need root to install system packages (run as root, or install: ${missing[*]})"
    exit 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# 2. Virtual environment.
if [[ ! -x "$venv/bin/python" ]]; then
  say "creating virtual environment $venv"
  "$python" -m venv "$venv"
fi
pip=("$venv/bin/python" -m pip --disable-pip-version-check -q)

# 3. The package, rebuilt only when its sources changed.
stamp="$venv/.rdmesh-source-hash"
hash=$(find pyproject.toml CMakeLists.txt cpp python/rdmesh -type f \( -name "*.py" -o -name "*.pyi" -o -name "*.cpp" -o -name "*.hpp" -o -name "*.toml" -o -name "*.txt" \) | LC_ALL=C sort | xargs cat | sha256sum | cut -d' ' -f1)
if [[ ! -f "$stamp" || "$(cat "$stamp")" != "$hash" ]] || ! "$venv/bin/python" -c "import rdmesh" 2>/dev/null; then
  say "building and installing rdmesh (C++ extension against CGAL; about a minute)"
  "${pip[@]}" install ".[render,progress,test]"
  echo "$hash" >"$stamp"
fi

# 3b. The documentation's packages (the `docs` extra of pyproject.toml), installed
#     on their own so that rdmesh is not rebuilt for them; again only when the
#     list changed or one is missing.
if [[ "$job" == docs ]]; then
  mapfile -t docs_requirements < <("$venv/bin/python" -c 'import tomllib; print("\n".join(tomllib.load(open("pyproject.toml", "rb"))["project"]["optional-dependencies"]["docs"]))')
  docs_stamp="$venv/.rdmesh-docs-hash"
  docs_hash=$(printf '%s\n' "${docs_requirements[@]}" | sha256sum | cut -d' ' -f1)
  if [[ ! -f "$docs_stamp" || "$(cat "$docs_stamp")" != "$docs_hash" ]] ||
    ! "$venv/bin/python" -c "import sphinx, pydata_sphinx_theme, numpydoc, sphinx_gallery, myst_parser, skimage, matplotlib" 2>/dev/null; then
    say "installing the documentation's packages: ${docs_requirements[*]}"
    "${pip[@]}" install "${docs_requirements[@]}"
    echo "$docs_hash" >"$docs_stamp"
  fi
fi

# 4. The job.
case "$job" in
  demo)
    exec "$venv/bin/rdmesh" demo "$@"
    ;;
  test)
    exec "$venv/bin/python" -m pytest -q tests "$@"
    ;;
  bench)
    exec "$venv/bin/python" benchmarks/bench_vs_cgal.py "$@"
    ;;
  docs)
    # -E re-reads every page, so that -W sees the warnings of unchanged pages
    # too; the gallery reruns only the examples that changed.
    say "building the documentation into docs/_build/html (warnings are errors)"
    exec "$venv/bin/python" -m sphinx -E -W --keep-going -b html docs docs/_build/html "$@"
    ;;
  *)
    say "unknown job '$job' (use demo, test, bench or docs)"
    exit 2
    ;;
esac
