#!/usr/bin/env bash
# Runs a command in a private network namespace whose only interface is loopback, with
# multicast on and a route for 224.0.0.0/4, so LCM (UDP multicast) works and no packet leaves
# the machine. Tests and the demo run the plant and the controller this way.
#
#   tools/netns.sh CMD [ARGS...]
#
# Inside, use the LCM URL  udpm://239.255.76.67:7667?ttl=0  (ttl=0: multicast stays on this
# host). The namespace ends with CMD; its exit status is CMD's. As root this is `unshare -n`;
# otherwise `unshare -rn`, which needs unprivileged user namespaces.
set -euo pipefail

if [ $# -eq 0 ] || [ "$1" = "-h" ] || [ "$1" = "--help" ]; then
  sed -n '2,11s/^# \{0,1\}//p' "$0" >&2
  [ $# -eq 0 ] && exit 2 || exit 0
fi

command -v unshare >/dev/null || { echo "netns.sh: unshare not found (Debian: util-linux)" >&2; exit 1; }
command -v ip >/dev/null || { echo "netns.sh: ip not found (Debian: iproute2)" >&2; exit 1; }

flags=(-n)
[ "$(id -u)" -eq 0 ] || flags=(-r -n)

# Probe first, so a refusal is one clear line rather than a failure from inside the command.
if ! error=$(unshare "${flags[@]}" true 2>&1); then
  echo "netns.sh: cannot create a network namespace (unshare ${flags[*]}: ${error##*: })." \
       "Run as root, or allow unprivileged user namespaces (sysctl kernel.unprivileged_userns_clone=1, user.max_user_namespaces > 0)," \
       "or in a container grant CAP_SYS_ADMIN." >&2
  exit 1
fi

exec unshare "${flags[@]}" -- bash -c '
  set -e
  ip link set dev lo up multicast on
  ip route add 224.0.0.0/4 dev lo
  exec "$@"' netns.sh "$@"
