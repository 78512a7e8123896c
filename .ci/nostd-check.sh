#!/usr/bin/env bash
# no_std check for the mesopush embedded crates.
#
# Usage: .ci/nostd-check.sh [crate...]   (default: mesopush-protocol mesopush-executor)
#
# Builds .ci/nostd-check, a #![no_std] #![no_main] binary with its own panic handler that
# exercises the listed crates, with the strongest check this machine allows:
#   1. bare metal: if `rustup target add thumbv7em-none-eabihf` succeeds, build for that
#      target, which has no `std` at all;
#   2. otherwise (or with NOSTD_CHECK_MODE=link): build for the host target with
#      panic=abort and -nostartfiles -nodefaultlibs, so std's runtime cannot link, and its
#      panic handler would clash with ours.
# Either way a self-test then builds the consumer with `extern crate std` and requires that
# build to FAIL, so the check is known to be able to fail. It prints which check ran and
# exits non-zero on any failure. Uses target/nostd-check, away from the workspace build.
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/.." && pwd)"
manifest="$here/nostd-check/Cargo.toml"
target_dir="$root/target/nostd-check"
bare_target="thumbv7em-none-eabihf"
log="$target_dir/last-build.log"
mkdir -p "$target_dir"

crates=("$@")
if [ ${#crates[@]} -eq 0 ]; then
    crates=(mesopush-protocol mesopush-executor)
fi
features=()
for crate in "${crates[@]}"; do
    case "$crate" in
        mesopush-protocol) ;; # always linked: the consumer is written against it
        *)
            if ! grep -q "^$crate = \[" "$manifest"; then
                echo "no_std check: unknown crate '$crate' (add it to $manifest [features])" >&2
                exit 2
            fi
            features+=("$crate")
            ;;
    esac
done
feature_list="$(IFS=,; echo "${features[*]:-}")"

mode="${NOSTD_CHECK_MODE:-auto}"
if [ "$mode" = "auto" ]; then
    if command -v rustup >/dev/null 2>&1 && rustup target add "$bare_target" >/dev/null 2>&1; then
        mode="bare-metal"
    else
        mode="link"
    fi
fi

build() { # build <extra features>; output goes to $log
    local feats="$feature_list"
    if [ -n "$1" ]; then feats="${feats:+$feats,}$1"; fi
    if [ "$mode" = "bare-metal" ]; then
        cargo build --release --manifest-path "$manifest" --target-dir "$target_dir" \
            --target "$bare_target" --features "$feats" >"$log" 2>&1
    else
        # An explicit --target keeps RUSTFLAGS off build scripts and proc macros.
        local host_target
        host_target="$(rustc -vV | sed -n 's/^host: //p')"
        RUSTFLAGS="-C panic=abort -C link-arg=-nostartfiles -C link-arg=-nodefaultlibs -C link-arg=-lc" \
            cargo build --release --manifest-path "$manifest" --target-dir "$target_dir/host" \
            --target "$host_target" --features "$feats" >"$log" 2>&1
    fi
}

if ! build ""; then
    cat "$log" >&2
    echo "no_std check ($mode) FAILED for: ${crates[*]}" >&2
    exit 1
fi
if build "canary-std"; then
    echo "no_std check ($mode) self-test FAILED: a consumer linking std built anyway" >&2
    exit 1
fi
if [ "$mode" = "bare-metal" ]; then
    echo "no_std check: bare-metal build for $bare_target OK (${crates[*]})"
else
    echo "no_std check: host link check (#![no_std] no_main, -nostartfiles -nodefaultlibs) OK" \
        "(${crates[*]}); bare-metal target $bare_target unavailable or not requested"
fi
echo "no_std check: self-test OK (a consumer with extern crate std fails to build)"
