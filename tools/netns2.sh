#!/usr/bin/env bash
# Two hosts on one machine: creates two network namespaces, A and B, joined by a veth pair
# (10.77.0.1/24 in A, 10.77.0.2/24 in B; the addresses exist only inside them), with multicast on
# and a route for 224.0.0.0/4 on the veth, and runs a command in A. The command starts processes
# in B with   nsenter --net="$CHASLES_NETNS_B" PROGRAM [ARGS...]
# Tests run the plant in A and the controller in B this way; no packet touches the host's
# interfaces.
#
#   tools/netns2.sh CMD [ARGS...]
#
# Use the LCM URL  udpm://239.255.76.67:7667?ttl=1  (ttl=1: one hop, across the veth). Both
# namespaces (and with them the veth pair) are removed when CMD ends, fails or is interrupted, or
# by the next run if this one was killed; the exit status is CMD's. Needs root (ip netns add).
set -euo pipefail

if [ $# -eq 0 ] || [ "$1" = "-h" ] || [ "$1" = "--help" ]; then
  sed -n '2,15s/^# \{0,1\}//p' "$0" >&2
  [ $# -eq 0 ] && exit 2 || exit 0
fi

for tool in ip nsenter; do
  command -v "$tool" >/dev/null || { echo "netns2.sh: $tool not found (Debian: iproute2, util-linux)" >&2; exit 1; }
done
if [ "$(id -u)" -ne 0 ]; then
  echo "netns2.sh: needs root to create named network namespaces (ip netns add); tools/netns.sh needs no root" >&2
  exit 1
fi

# Namespaces a killed run left behind (SIGKILL runs no trap): removed once their script is gone.
for ns in $(ip netns list | awk '/^chasles-[0-9]+-[ab]( |$)/ {print $1}'); do
  pid=${ns#chasles-}
  kill -0 "${pid%-*}" 2>/dev/null || ip netns del "$ns" 2>/dev/null || true
done

# Unique per run, so parallel runs do not meet.
a="chasles-$$-a" b="chasles-$$-b"
cleanup() {
  ip netns del "$a" 2>/dev/null || true  # deleting a namespace deletes its end of the veth, and so the pair
  ip netns del "$b" 2>/dev/null || true
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

ip netns add "$a"
ip netns add "$b"
# Created inside A, so the pair never exists in the host's namespace even for a moment.
ip -n "$a" link add veth-a type veth peer name veth-b netns "$b"
setup() {  # namespace, interface, address
  ip -n "$1" link set dev lo up
  ip -n "$1" addr add "$3/24" dev "$2"
  ip -n "$1" link set dev "$2" up multicast on
  ip -n "$1" route add 224.0.0.0/4 dev "$2"
}
setup "$a" veth-a 10.77.0.1
setup "$b" veth-b 10.77.0.2

# Not exec: the trap must run after CMD to remove the namespaces.
status=0
CHASLES_NETNS_B="/run/netns/$b" nsenter --net="/run/netns/$a" -- "$@" || status=$?
exit "$status"
