#!/bin/bash
# The image's HEALTHCHECK: exit 0 when GET /healthz on this container answers 200, else 1.
# bash's /dev/tcp speaks the one request this needs, so the image carries no curl (and no libcurl, ssh, http2 libs).
# TRACEMESH_HEALTH_PORT: the port tracemeshd listens on (8080 unless the entry point was changed).
port=${TRACEMESH_HEALTH_PORT:-8080}
exec 3<>"/dev/tcp/127.0.0.1/$port" || exit 1
printf 'GET /healthz HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n' >&3
IFS= read -r -t 4 status_line <&3 || exit 1
[[ $status_line == "HTTP/1.1 200 "* ]]
