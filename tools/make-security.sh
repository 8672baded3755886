#!/usr/bin/env bash
# DDS-Security identities for densemap (Fast DDS 2.9's builtin plugins: PKI-DH authentication,
# Access-Permissions with a signed governance and signed permissions, AES-GCM-GMAC), made with Debian's openssl.
#
#   tools/make-security.sh DIR [--robots N] [--clients M] [--ros2-robots K] [--days D] [--namespace NS]
#   tools/make-security.sh DIR --add ROLE NAME [--days D | --valid-until DATE] [--valid-from DATE]
#   tools/make-security.sh DIR --revoke NAME
#   tools/make-security.sh DIR --rotate-ca [--days D]
#
# Makes a CA and one folder per identity: DIR/server, DIR/robot-1..N, DIR/client-1..M, DIR/operator (and
# DIR/ros2-robot-1..K). Each holds what its program needs, under the file names of an SROS2 enclave:
# cert.pem, key.pem, identity_ca.cert.pem, permissions_ca.cert.pem, governance.p7s, permissions.p7s (and
# permissions.xml, the signed text), crl.pem. Run a program with `--security-dir DIR/<identity>`.
# ROLE is server, robot, client, operator or ros2-robot. DATE is anything `date -d` reads ("+5 seconds",
# "2027-06-30 12:00"). Defaults: 1 robot, 1 client, 365 days, no namespace. DIR itself is laid out as an
# SROS2 keystore (public/, private/, enclaves/governance.p7s), so `ros2 security create_enclave DIR /name`
# adds a ROS 2 enclave that densemap trusts. DIR/private holds the CA's key: keep it off the robots.
set -euo pipefail
usage() { sed -n '2,18p' "$0" | sed 's/^# \{0,1\}//'; }
die() {
  echo "make-security: $*" >&2
  exit 2
}

[ $# -gt 0 ] || {
  usage >&2
  exit 2
}
case "$1" in -h | --help)
  usage
  exit 0
  ;;
esac
dir="$1"
shift
robots=1 clients=1 ros2_robots=0 days=365 namespace="" mode=create add_role="" add_name="" revoke_name=""
valid_from="" valid_until=""
while [ $# -gt 0 ]; do
  case "$1" in
    --robots) robots="${2:-}"; shift 2 ;;
    --clients) clients="${2:-}"; shift 2 ;;
    --ros2-robots) ros2_robots="${2:-}"; shift 2 ;;
    --days) days="${2:-}"; shift 2 ;;
    --namespace) namespace="${2:-}"; shift 2 ;;
    --add) mode=add; add_role="${2:-}"; add_name="${3:-}"; shift 3 || die "--add needs ROLE NAME" ;;
    --revoke) mode=revoke; revoke_name="${2:-}"; shift 2 || die "--revoke needs NAME" ;;
    --rotate-ca) mode=rotate; shift ;;
    --valid-from) valid_from="${2:-}"; shift 2 ;;
    --valid-until) valid_until="${2:-}"; shift 2 ;;
    -h | --help) usage; exit 0 ;;
    *) usage >&2; die "unknown argument '$1'" ;;
  esac
done
for v in robots clients ros2_robots days; do
  [[ "${!v}" =~ ^[0-9]+$ ]] || die "--${v//_/-} must be a whole number, not '${!v}'"
done
[ "$days" -ge 1 ] || die "--days must be at least 1"
[[ -z "$namespace" || "$namespace" =~ ^[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z0-9_]+)*$ ]] ||
  die "--namespace '$namespace' is not a topic namespace (letters, digits, _ and /, not starting with a digit)"
command -v openssl > /dev/null || die "openssl is missing: apt-get install openssl"
[[ "$dir" =~ [[:space:]] ]] && die "DIR must not contain white space ('$dir'): openssl's configuration cannot quote it"
mkdir -p "$dir"
dir="$(cd "$dir" && pwd)"
private="$dir/private" public="$dir/public" db="$dir/private/ca"
settings="$private/settings" identities="$private/identities.txt"

valid_name() { [[ "$1" =~ ^[A-Za-z0-9][A-Za-z0-9_.-]{0,62}$ ]]; }
# An id as it stands in a topic name: the one-to-one escape of idl/include/densemap/msg/peer_topic.h
# ('_' -> __, '-' -> _h, '.' -> _d), so every name is one any DDS accepts and robot-0 never meets robot_0.
topic_name() { local s="${1//_/__}"; s="${s//-/_h}"; echo "${s//./_d}"; }
stamp() { date -u -d "$1" +%Y%m%d%H%M%SZ 2> /dev/null || die "cannot read the date '$1'"; }
xml_time() { date -u -d "$1" +%Y-%m-%dT%H:%M:%S; }

# The openssl CA: its database under private/ca, certificates valid for the given time, a CRL that stays
# valid as long as the CA (an expired CRL makes OpenSSL refuse every certificate).
write_ca_config() {
  mkdir -p "$db/certs"
  [ -f "$db/index.txt" ] || : > "$db/index.txt"
  [ -f "$db/serial" ] || echo 1000 > "$db/serial"
  [ -f "$db/crlnumber" ] || echo 1000 > "$db/crlnumber"
  cat > "$db/openssl.cnf" << EOF
[ ca ]
default_ca = densemap_ca
[ densemap_ca ]
dir = $db
database = $db/index.txt
new_certs_dir = $db/certs
serial = $db/serial
crlnumber = $db/crlnumber
certificate = $public/ca.cert.pem
private_key = $private/ca.key.pem
default_md = sha256
default_days = 365
default_crl_days = 3650
policy = policy_cn
unique_subject = no
copy_extensions = none
x509_extensions = identity_ext
[ policy_cn ]
commonName = supplied
[ identity_ext ]
basicConstraints = critical, CA:FALSE
keyUsage = critical, digitalSignature
subjectKeyIdentifier = hash
authorityKeyIdentifier = keyid
EOF
}

make_ca() {
  mkdir -p "$private" "$public" "$dir/enclaves"
  chmod 700 "$private"
  openssl ecparam -name prime256v1 -genkey -noout -out "$private/ca.key.pem" 2> /dev/null
  chmod 600 "$private/ca.key.pem"
  openssl req -x509 -new -key "$private/ca.key.pem" -sha256 -days "$((days > 3650 ? days : 3650))" \
    -subj "/CN=densemap CA $(date -u +%Y-%m-%dT%H:%M:%SZ)" \
    -addext "basicConstraints=critical,CA:TRUE" -addext "keyUsage=critical,digitalSignature,keyCertSign,cRLSign" \
    -out "$public/ca.cert.pem" 2> /dev/null
  # One CA signs identities and permissions (SROS2's layout names both).
  for n in identity_ca permissions_ca; do
    cp "$public/ca.cert.pem" "$public/$n.cert.pem"
    cp "$private/ca.key.pem" "$private/$n.key.pem"
  done
  rm -rf "$db"
  write_ca_config
  openssl ca -batch -config "$db/openssl.cnf" -gencrl -out "$public/crl.pem" 2> /dev/null
}

sign() { # file.xml -> file.p7s, S/MIME signed by the CA (what Access-Permissions verifies)
  openssl smime -sign -in "$1" -text -out "$2" -signer "$public/ca.cert.pem" -inkey "$private/ca.key.pem"
}

# The governance, one for the whole domain range: no unauthenticated participant joins, discovery and
# liveliness are encrypted, RTPS messages are signed (GMAC), and on every topic access is checked on both
# sides and both the data and its metadata are encrypted (AES-GCM).
make_governance() {
  cat > "$dir/enclaves/governance.xml" << 'EOF'
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>232</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
EOF
  sign "$dir/enclaves/governance.xml" "$dir/enclaves/governance.p7s"
}

topics() { # <topic> elements, each name under the namespace
  local t
  for t in "$@"; do
    case "$t" in
      densemap/*) echo "          <topic>${namespace:+$namespace/}$t</topic>" ;;
      *) echo "          <topic>$t</topic>" ;;
    esac
  done
}

rule() { # allow_rule|deny_rule, then "publish: a b" "subscribe: c d"
  local kind="$1" part what
  shift
  echo "      <$kind>"
  echo "        <domains><id_range><min>0</min><max>232</max></id_range></domains>"
  for part in "$@"; do
    what="${part%%:*}"
    read -r -a names <<< "${part#*:}"
    [ ${#names[@]} -gt 0 ] || continue
    echo "        <$what><topics>"
    topics "${names[@]}"
    echo "        </topics></$what>"
  done
  echo "      </$kind>"
}

# What each role may publish and subscribe to. Replies go to a topic per client (.../reply/<name>, or
# .../reply/<name>.<k> for a program's k-th client, written .../reply/<name>_d<k>), which only that identity
# may read. A robot's scans, acknowledgements and progress go on topics of its own (.../scans/<name>, or
# .../scans/<name>-<k> for a program publishing for several robots, written .../scans/<name>_h<k>), which only that identity may write or read: the server checks each
# scan's robot id against its topic, so a robot cannot send as another or read another's acknowledgements. The ROS 2 edge's topics are ROS 2's (rt/ topics, rq/ and rr/ services).
permission_rules() { # role name
  local role="$1" name
  name="$(topic_name "$2")"
  case "$role" in
    server)
      rule allow_rule \
        "publish: densemap/scan_acks/* densemap/query/reply/* densemap/admin/reply/* densemap/statistics densemap/robot_progress densemap/robot_progress/* rt/* rr/* ros_discovery_info" \
        "subscribe: densemap/scans/* densemap/query/request densemap/admin/request densemap/statistics rt/* rq/* ros_discovery_info"
      ;;
    robot)
      rule allow_rule "publish: densemap/scans/$name densemap/scans/${name}_h*" \
        "subscribe: densemap/scan_acks/$name densemap/scan_acks/${name}_h* densemap/robot_progress/$name densemap/robot_progress/${name}_h* densemap/statistics"
      ;;
    client)
      rule allow_rule "publish: densemap/query/request" \
        "subscribe: densemap/query/reply/$name densemap/query/reply/${name}_d* densemap/statistics"
      ;;
    operator)
      rule allow_rule "publish: densemap/admin/request densemap/query/request" \
        "subscribe: densemap/admin/reply/$name densemap/admin/reply/${name}_d* densemap/query/reply/$name densemap/query/reply/${name}_d* densemap/statistics densemap/robot_progress"
      ;;
    ros2-robot)
      # A ROS 2 robot publishes its clouds and transforms, reads the maps and offers its own nodes' services
      # (rclcpp's parameter services); the maps, their services and the clearing and reset services are the
      # server's and the operator's.
      rule deny_rule \
        "publish: rt/*octomap_binary rt/*octomap_full rt/*projected_map rt/*octomap_point_cloud_centers rq/*clear_bbox* rq/*reset* rr/*octomap_binary* rr/*octomap_full*"
      rule allow_rule "publish: rt/* rq/* ros_discovery_info" "subscribe: rt/* rr/* ros_discovery_info"
      ;;
    *) die "unknown role '$role' (server, robot, client, operator, ros2-robot)" ;;
  esac
}

make_identity() { # role name
  local role="$1" name="$2" out="$dir/$2" start end from until
  valid_name "$name" || die "'$name' is not an identity name (letters, digits, _ . -; at most 63)"
  from="${valid_from:-now}"
  until="${valid_until:-+$days days}"
  start="$(stamp "$from")"
  end="$(stamp "$until")"
  [[ "$end" > "$start" ]] || die "the identity '$name' would expire ($until) before it is valid ($from)"
  mkdir -p "$out"
  openssl ecparam -name prime256v1 -genkey -noout -out "$out/key.pem" 2> /dev/null
  chmod 600 "$out/key.pem"
  openssl req -new -key "$out/key.pem" -subj "/CN=$name" -out "$out/cert.csr" 2> /dev/null
  openssl ca -batch -config "$db/openssl.cnf" -notext -startdate "$start" -enddate "$end" \
    -in "$out/cert.csr" -out "$out/cert.pem" 2> "$out/ca.log" || {
    cat "$out/ca.log" >&2
    die "openssl ca could not sign '$name'"
  }
  rm -f "$out/cert.csr" "$out/ca.log"
  {
    cat << EOF
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$name">
      <subject_name>CN=$name</subject_name>
      <validity>
        <not_before>$(xml_time "$from")</not_before>
        <not_after>$(xml_time "$until")</not_after>
      </validity>
EOF
    permission_rules "$role" "$name"
    cat << EOF
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
EOF
  } > "$out/permissions.xml"
  sign "$out/permissions.xml" "$out/permissions.p7s"
  cp "$public/identity_ca.cert.pem" "$public/permissions_ca.cert.pem" "$public/crl.pem" \
    "$dir/enclaves/governance.p7s" "$out/"
  echo "$role" > "$out/role"
  grep -v "^$name " "$identities" 2> /dev/null > "$identities.new" || true
  echo "$name $role" >> "$identities.new"
  mv "$identities.new" "$identities"
  echo "make-security: $role '$name' in $out (valid until $(date -u -d "$until" '+%Y-%m-%d %H:%M:%S') UTC)"
}

case "$mode" in
  create)
    [ ! -f "$public/ca.cert.pem" ] || die "$dir already holds a CA: use --add, --revoke or --rotate-ca, or another DIR"
    make_ca
    echo "namespace=$namespace" > "$settings"
    make_governance
    make_identity server server
    make_identity operator operator
    for i in $(seq 1 "$robots"); do make_identity robot "robot-$i"; done
    for i in $(seq 1 "$clients"); do make_identity client "client-$i"; done
    for i in $(seq 1 "$ros2_robots"); do make_identity ros2-robot "ros2-robot-$i"; done
    ;;
  add)
    [ -f "$public/ca.cert.pem" ] || die "$dir holds no CA: make it first (tools/make-security.sh $dir)"
    namespace="$(sed -n 's/^namespace=//p' "$settings")"
    write_ca_config
    [ ! -e "$dir/$add_name" ] || die "$dir/$add_name exists already: revoke it first, or pick another name"
    make_identity "$add_role" "$add_name"
    ;;
  revoke)
    [ -f "$dir/$revoke_name/cert.pem" ] || die "no identity '$revoke_name' in $dir"
    write_ca_config
    openssl ca -batch -config "$db/openssl.cnf" -revoke "$dir/$revoke_name/cert.pem" 2> /dev/null ||
      die "openssl ca could not revoke '$revoke_name'"
    openssl ca -batch -config "$db/openssl.cnf" -gencrl -out "$public/crl.pem" 2> /dev/null
    mkdir -p "$private/revoked"
    mv "$dir/$revoke_name" "$private/revoked/$revoke_name-$(date -u +%Y%m%dT%H%M%SZ)"
    grep -v "^$revoke_name " "$identities" > "$identities.new" || true
    mv "$identities.new" "$identities"
    while read -r name _; do cp "$public/crl.pem" "$dir/$name/crl.pem"; done < "$identities"
    echo "make-security: revoked '$revoke_name'; copy the new crl.pem (in every folder) to the server and restart it"
    ;;
  rotate)
    [ -f "$identities" ] || die "$dir holds no identities to rotate"
    namespace="$(sed -n 's/^namespace=//p' "$settings")"
    retired="$private/retired-$(date -u +%Y%m%dT%H%M%SZ)"
    mkdir -p "$retired"
    cp -r "$public" "$retired/public"
    cp "$private/ca.key.pem" "$retired/"
    make_ca
    make_governance
    while read -r name role; do
      rm -rf "${dir:?}/$name"
      make_identity "$role" "$name"
    done < <(cat "$identities")
    echo "make-security: new CA; every identity re-issued (the old CA is in $retired): deploy every folder, then restart"
    ;;
esac
