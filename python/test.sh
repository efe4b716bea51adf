#!/usr/bin/env bash
# The Python package's tests (issue 34): a fresh virtual environment in target/pyvenv, the
# package built into it by `pip install ./python` (maturin), then pytest against the command
# line of the same checkout. `.ci/run` runs this after `cargo test`.
#
# The package is built with cargo's dev profile (MATURIN_PEP517_ARGS, default "--profile dev"
# with texgraph unoptimised, below) so it reuses the dependencies `cargo test` compiled;
# `pip install ./python` without it builds the optimised release a user gets.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/pyvenv
# TEXGRAPH_PYVENV_READY=1: the environment was made by this run already (.ci/run makes it, with
# NumPy, pytest and maturin, while cargo builds); it is used if it is complete.
if [ "${TEXGRAPH_PYVENV_READY:-}" != 1 ] || [ ! -f "$venv/.ready" ]; then
    rm -rf "$venv"
    python3 -m venv "$venv"
    "$venv/bin/python" -m pip install --quiet --upgrade pip
    "$venv/bin/python" -m pip install --quiet numpy pytest "maturin>=1.7,<2"
fi
# The command line the tests run: TEXGRAPH_CLI when the caller built it (.ci/run), else the one
# `cargo test` builds (its dependencies' features are unified with the tests' dev-dependencies;
# `cargo build --bin texgraph` would rebuild naga, serde, hyper and the crate with other
# features: 52 s in CI), a no-op after `cargo test`.
if [ -z "${TEXGRAPH_CLI:-}" ]; then
    cargo test --locked --no-run --test it --quiet
    TEXGRAPH_CLI="$PWD/target/debug/texgraph"
fi
if [ -n "${TEXGRAPH_PY_MODULE:-}" ]; then
    # The extension module built already (.ci/run: `cargo build --workspace --all-targets`
    # builds it with the test build, whose texgraph and dependencies it shares, instead of a
    # third build of the crate by maturin, 100 s of 2 cores), installed as maturin lays it out:
    # python/texgraph/ with the module inside as texgraph/_texgraph.abi3.so. `bash .ci/run --full`
    # builds and installs it with pip and maturin, the way a user does.
    site=$("$venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
    rm -rf "$site/texgraph"
    cp -r python/texgraph "$site/texgraph"
    cp "$TEXGRAPH_PY_MODULE" "$site/texgraph/_texgraph.abi3.so"
else
    # maturin is in the environment: no isolated build environment to make (and download) again.
    # The binding's texgraph has other features than the test build's (no GPU path), so it is a
    # build of its own: unoptimised (the profile's opt-level 1 for the crate doubles its build
    # time to 200 s on 2 cores, for tests that then take 6 s instead of 12).
    PATH="$PWD/$venv/bin:$PATH" MATURIN_PEP517_ARGS="${MATURIN_PEP517_ARGS:---profile dev --config profile.dev.package.texgraph.opt-level=0}" \
        "$venv/bin/python" -m pip install --quiet --no-build-isolation ./python
fi
# pytest from the repository root, so `import texgraph` finds the installed package and not
# the source folder python/texgraph.
TEXGRAPH_CLI="$TEXGRAPH_CLI" "$venv/bin/python" -m pytest -q -p no:cacheprovider python/tests "$@"
