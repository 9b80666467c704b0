#!/usr/bin/env bash
# Make the files of a secured mosquitto for fvtree's design link (README: "A secured broker for a
# lab"): a lab CA and the broker's TLS certificate, a password file with one user per cell, the
# coordinator and a designer, the ACL file, a mosquitto.conf using them, and one credentials file
# per user (JSON, mode 600: login, the CA, and the signing secrets cells share with the coordinator).
#
#   examples/secure_broker/make_lab.sh DIR HOST CELL [CELL ...]
#
# DIR: where the files go (e.g. /etc/mosquitto/fvtree); HOST: the broker's name or IP address as the
# cells reach it (in its certificate); CELL: each cell's --cell-name. Environment: PORT (TLS
# listener, default 8883), BIND (address to listen on, default all). Run it again with new cells
# only on a fresh DIR: it refuses to overwrite a lab.
set -euo pipefail
if [ $# -lt 3 ]; then sed -n '7,12p' "$0"; exit 2; fi
dir=$1; host=$2; shift 2
here=$(cd "$(dirname "$0")" && pwd)
port=${PORT:-8883}
if [ -e "$dir/passwd" ]; then echo "$dir/passwd exists: not overwriting a lab" >&2; exit 2; fi
umask 077
mkdir -p "$dir/credentials"
cd "$dir"

# 1. The lab CA and the broker's certificate (its subjectAltName is what clients check).
san="DNS:$host"
if [[ $host =~ ^[0-9.]+$ ]]; then san="IP:$host"; fi
openssl req -x509 -newkey rsa:2048 -nodes -days 3650 -subj "/CN=fvtree lab CA" \
    -keyout ca.key -out ca.crt 2>/dev/null
openssl req -newkey rsa:2048 -nodes -subj "/CN=$host" -keyout server.key -out server.csr 2>/dev/null
printf 'subjectAltName=%s\n' "$san" > server.ext
openssl x509 -req -in server.csr -CA ca.crt -CAkey ca.key -CAcreateserial -days 825 \
    -extfile server.ext -out server.crt 2>/dev/null
chmod 644 ca.crt server.crt

# 2. Users: each cell (its user name is its cell name: the ACL keys its topics by it), the
#    coordinator and a designer; a random password each, and a signing secret per cell.
: > passwd
declare -A secret
for user in coordinator designer "$@"; do
    password=$(openssl rand -hex 16)
    mosquitto_passwd -b passwd "$user" "$password"
    entry="\"username\": \"$user\", \"password\": \"$password\", \"ca\": \"../ca.crt\""
    if [ "$user" != coordinator ] && [ "$user" != designer ]; then
        secret[$user]=$(openssl rand -hex 32)
        entry="$entry, \"secret\": \"${secret[$user]}\""
    fi
    printf '{%s}\n' "$entry" > "credentials/$user.json"
done
cells=""
for cell in "$@"; do cells="$cells${cells:+, }\"$cell\": \"${secret[$cell]}\""; done
sed -i "s/}\$/, \"cells\": {$cells}}/" credentials/coordinator.json
chmod 600 credentials/*.json

# 3. The ACL and the broker's configuration.
cp "$here/acl" acl
cat > mosquitto.conf <<EOF
# fvtree design link, made by make_lab.sh: logins only, ACLs, TLS only.
per_listener_settings false
allow_anonymous false
persistence false
password_file $dir/passwd
acl_file $dir/acl
listener $port ${BIND:-}
cafile $dir/ca.crt
certfile $dir/server.crt
keyfile $dir/server.key
tls_version tlsv1.2
require_certificate false
EOF
# mosquitto started as root reads its files as the mosquitto user.
if [ "$(id -u)" = 0 ] && id mosquitto >/dev/null 2>&1; then
    chown mosquitto: passwd acl server.key mosquitto.conf
    chmod 755 "$dir"
fi
rm -f server.csr server.ext ca.srl
echo "made $dir: mosquitto -c $dir/mosquitto.conf; credentials in $dir/credentials/ (keep ca.key offline)"
