#!/bin/sh
# use-apt-mirror [URL]: points the image's Debian sources at URL (e.g. a lab's local mirror) instead of
# deb.debian.org; without an argument it leaves them as they are. The security suite keeps its own host unless the
# mirror carries it too (then pass the sources yourself: docs/deploy.md).
set -eu
mirror=${1:-}
[ -n "$mirror" ] || exit 0
for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.sources /etc/apt/sources.list.d/*.list; do
  [ -f "$f" ] && sed -i "s#https\?://deb\.debian\.org/debian\([ /]\|\$\)#${mirror%/}\1#g" "$f"
done
exit 0
