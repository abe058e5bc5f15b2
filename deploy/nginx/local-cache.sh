#!/usr/bin/env bash
# Writes DIR/nginx.conf: deploy/nginx/pointlocalization-cache.conf as a cache tier on this machine, its
# cache, temporary files, pid and logs under DIR (for the tests and the benchmarks). Run nginx with
#   nginx -p DIR -c DIR/nginx.conf -e DIR/error.log
# Started as root, its workers become nobody, who must write the cache and the bodies being relayed.
#   deploy/nginx/local-cache.sh DIR LISTEN "server HOST:PORT; ..." WORKER_CONNECTIONS [OPEN_FILES]
# OPEN_FILES: the workers' limit of open files (worker_rlimit_nofile; default: the system's).
set -euo pipefail
usage="usage: local-cache.sh DIR LISTEN ORIGINS WORKER_CONNECTIONS [OPEN_FILES]"
dir=${1:?$usage}
listen=${2:?$usage}
origins=${3:?$usage}
connections=${4:?$usage}
open_files=${5:+worker_rlimit_nofile $5;}
site=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/pointlocalization-cache.conf
mkdir -p "$dir/cache" "$dir/tmp"
sed -e "s|@LISTEN@|$listen|" -e "s|@ORIGINS@|$origins|" -e "s|@CACHE_DIR@|$dir/cache|" "$site" >"$dir/cache.conf"
user=
if [[ $(id -u) = 0 ]]; then
  user="user nobody $(id -gn nobody);"
  chown -R nobody "$dir/cache" "$dir/tmp"
fi
cat >"$dir/nginx.conf" <<CONF
$user
daemon off;
worker_processes 2;
$open_files
pid $dir/nginx.pid;
error_log $dir/error.log warn;
events { worker_connections $connections; }
http {
  access_log off;
  client_body_temp_path $dir/tmp/body;
  proxy_temp_path $dir/tmp/proxy;
  fastcgi_temp_path $dir/tmp/fastcgi;
  uwsgi_temp_path $dir/tmp/uwsgi;
  scgi_temp_path $dir/tmp/scgi;
  include $dir/cache.conf;
}
CONF
