#!/usr/bin/env bash
# Checks docker/nginx (the compose profile's nginx configuration) for real: nginx runs docker/nginx/tracemesh.conf
# and then tracemesh-tls.conf (with a throw-away self-signed certificate), with only the upstream address, the ports
# and the file paths made local, in front of a running tracemeshd. Through each: /healthz 200 and POST /mesh of fas2
# byte for byte as tracemeshd answers it directly (so the body limit, request streaming and proxying work); the TLS
# configuration's plain-HTTP server answers 301. With --tracemeshd (run with --trusted-proxy 127.0.0.1), a request
# from 127.0.0.2 carrying a forged Forwarded and X-Forwarded-For is logged by tracemeshd as client 127.0.0.2: nginx
# appends the real client and drops the client's Forwarded.
# Usage: tests/image/nginx_check.sh --port PORT          (a tracemeshd already listening on 127.0.0.1:PORT)
#        tests/image/nginx_check.sh --tracemeshd BINARY  (starts BINARY --no-disk-store on a free port: ctest)
# Exit 77 (ctest: skipped) when nginx or openssl is not installed.
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
molecules=$repo/tests/data/molecules  # fas2.pqr, kept in the repository

fail() { printf 'nginx_check: FAIL: %s\n' "$*" >&2; exit 1; }
command -v nginx >/dev/null && command -v openssl >/dev/null || { echo "nginx_check: nginx or openssl missing"; exit 77; }

work=$(mktemp -d /tmp/tracemesh-nginx.XXXXXX)
server_pid="" nginx_pid=""
cleanup() {
  [[ -n $nginx_pid ]] && kill -TERM "$nginx_pid" 2>/dev/null || true  # TERM: the master stops its workers
  [[ -n $server_pid ]] && kill -TERM "$server_pid" 2>/dev/null || true
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

case ${1:-} in
  --port) port=${2:?--port needs a port} ;;
  --tracemeshd)
    "${2:?--tracemeshd needs the binary}" --listen 127.0.0.1:0 --no-disk-store --workers 1 --trusted-proxy 127.0.0.1 \
      >"$work/tracemeshd.log" 2>&1 &
    server_pid=$!
    port=""
    for _ in $(seq 100); do
      port=$(sed -n 's/.*"event":"started".*"port":\([0-9]*\).*/\1/p' "$work/tracemeshd.log" | head -1)
      [[ -n $port ]] && break
      kill -0 "$server_pid" 2>/dev/null || fail "tracemeshd exited at start: $(tail -3 "$work/tracemeshd.log")"
      sleep 0.1
    done
    [[ -n $port ]] || fail "tracemeshd logged no 'started' line with its port" ;;
  *) echo "usage: $0 --port PORT | --tracemeshd BINARY" >&2; exit 2 ;;
esac

code=$(curl -s -o "$work/direct.off" -w '%{http_code}' -F pqr=@"$molecules/fas2.pqr" "http://127.0.0.1:$port/mesh") \
  || fail "POST /mesh to tracemeshd on port $port: no answer"
[[ $code == 200 ]] || fail "POST /mesh fas2 to tracemeshd answered $code"

# start_nginx NAME SERVER_CONF: nginx with that server file; sets nginx_port (the TLS listener, or the plain one)
# and redirect_port (the plain-HTTP listener).
start_nginx() {
  local dir=$work/$1 conf=$2
  mkdir -p "$dir"
  for _ in 1 2 3 4 5; do
    nginx_port=$((20000 + RANDOM % 40000)); redirect_port=$((nginx_port + 1))
    sed -e "s|server tracemesh:8080;|server 127.0.0.1:$port;|" "$repo/docker/nginx/upstream.conf" >"$dir/upstream.conf"
    sed -e "s|listen 80;|listen 127.0.0.1:$redirect_port;|" -e "s|listen 443 |listen 127.0.0.1:$nginx_port |" \
        -e "s|/etc/nginx/tracemesh/upstream.conf|$dir/upstream.conf|" \
        -e "s|/etc/nginx/tracemesh/proxy.conf|$repo/docker/nginx/proxy.conf|" -e "s|/etc/nginx/certs/|$work/|" \
        "$conf" >"$dir/server.conf"
    # The plain file has only its port-80 server: that is the one to test.
    grep -q "listen 127.0.0.1:$nginx_port " "$dir/server.conf" || nginx_port=$redirect_port
    cat >"$dir/nginx.conf" <<CONF
user root root;
worker_processes 1;
pid $dir/nginx.pid;
error_log $dir/error.log;
events { worker_connections 64; }
http {
  access_log $dir/access.log;
  client_body_temp_path $dir/body; proxy_temp_path $dir/proxy;
  fastcgi_temp_path $dir/fastcgi; uwsgi_temp_path $dir/uwsgi; scgi_temp_path $dir/scgi;
  include $dir/server.conf;
}
CONF
    nginx -t -q -p "$dir" -c "$dir/nginx.conf" 2>"$dir/test.log" || fail "nginx rejects $conf: $(cat "$dir/test.log")"
    nginx -p "$dir" -c "$dir/nginx.conf" -g 'daemon off;' 2>>"$dir/error.log" &
    nginx_pid=$!
    for _ in $(seq 50); do
      curl -s -o /dev/null "http://127.0.0.1:$redirect_port/" 2>/dev/null && return 0
      kill -0 "$nginx_pid" 2>/dev/null || break
      sleep 0.1
    done
    kill -TERM "$nginx_pid" 2>/dev/null || true; wait "$nginx_pid" 2>/dev/null || true; nginx_pid=""
  done
  fail "nginx with $conf did not start: $(tail -3 "$dir/error.log")"
}
stop_nginx() { kill -QUIT "$nginx_pid"; wait "$nginx_pid" 2>/dev/null || true; nginx_pid=""; }
# through_nginx URL: /healthz 200 and fas2's mesh byte for byte as tracemeshd gave it.
through_nginx() {
  local url=$1 code
  code=$(curl -sk -o /dev/null -w '%{http_code}' "$url/healthz") || fail "GET $url/healthz: no answer"
  [[ $code == 200 ]] || fail "GET /healthz through nginx ($url) answered $code"
  code=$(curl -sk -o "$work/via-nginx.off" -w '%{http_code}' -F pqr=@"$molecules/fas2.pqr" "$url/mesh") \
    || fail "POST $url/mesh: no answer"
  [[ $code == 200 ]] || fail "POST /mesh fas2 through nginx ($url) answered $code"
  cmp -s "$work/direct.off" "$work/via-nginx.off" || fail "the mesh through nginx ($url) differs from tracemeshd's"
  [[ -n $server_pid ]] || return 0  # a server started elsewhere: its log and trust are not ours to check
  local id=nginx-check-$RANDOM$RANDOM
  code=$(curl -sk --interface 127.0.0.2 -o /dev/null -w '%{http_code}' -H "X-Request-Id: $id" \
    -H 'Forwarded: for=192.0.2.1' -H 'X-Forwarded-For: 192.0.2.2' "$url/healthz") || fail "GET $url/healthz from 127.0.0.2: no answer"
  [[ $code == 200 ]] || fail "GET /healthz from 127.0.0.2 through nginx ($url) answered $code"
  for _ in $(seq 50); do grep -q "\"request_id\":\"$id\"" "$work/tracemeshd.log" && break; sleep 0.1; done
  grep "\"request_id\":\"$id\"" "$work/tracemeshd.log" | grep -q '"client":"127.0.0.2"' \
    || fail "tracemeshd did not log the client nginx forwarded ($url): $(grep "$id" "$work/tracemeshd.log")"
}

start_nginx plain "$repo/docker/nginx/tracemesh.conf"
through_nginx "http://127.0.0.1:$nginx_port"
stop_nginx
openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -subj /CN=localhost -days 1 \
  -keyout "$work/tls.key" -out "$work/tls.crt" 2>/dev/null || fail "openssl could not make a test certificate"
start_nginx tls "$repo/docker/nginx/tracemesh-tls.conf"
through_nginx "https://127.0.0.1:$nginx_port"
code=$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:$redirect_port/healthz")
[[ $code == 301 ]] || fail "plain HTTP on the TLS configuration answered $code, expected 301 to https"
stop_nginx
echo "nginx_check: docker/nginx's plain and TLS configurations proxy /healthz and POST /mesh; HTTP → 301 HTTPS"
