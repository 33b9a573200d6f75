# Sourced by the setup scripts: Debian packages installed when missing.

# apt_install PACKAGE...: install those of the packages that dpkg does not know, with
# apt-get, quietly; returns 1 (installing nothing) when some are missing and this is not
# root with apt-get. The caller's `say` reports what it installs.
apt_install() {
    local missing=() pkg
    for pkg in "$@"; do
        dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
    done
    [ ${#missing[@]} -eq 0 ] && return 0
    if [ "$(id -u)" != "0" ] || ! command -v apt-get >/dev/null 2>&1; then
        APT_MISSING="${missing[*]}"
        return 1
    fi
    say "installing ${missing[*]} with apt-get"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq >/dev/null
    apt-get install -y -qq "${missing[@]}" >/dev/null
}
