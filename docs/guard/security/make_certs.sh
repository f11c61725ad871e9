#!/usr/bin/env bash
# A test CA and what DDS Security needs for `rosguard guard` and the programs that signal it:
# one CA (identity and permissions), per participant NAME a certificate and key, the domain's
# governance and each participant's permissions, signed by the CA (S/MIME, as DDS Security
# expects). For trying the guard's security and for tests: a real deployment keeps its CA's key
# offline and issues certificates its own way.
# Usage: make_certs.sh OUT_DIR NAME...      e.g. make_certs.sh /etc/rosguard/dds guard planner
# Writes OUT_DIR/ca.pem (+ ca.key), OUT_DIR/NAME.pem, NAME.key, governance.p7s, permissions_NAME.p7s
# (and the .xml they were signed from). Subjects are "CN=NAME,O=rosguard"; the governance below
# admits only authenticated participants to domains 0-230 and protects every topic (signed and
# encrypted data, access control on reading and writing): edit governance.xml and sign again to
# change that.
set -euo pipefail
out=${1:?usage: make_certs.sh OUT_DIR NAME...}
shift
[[ $# -ge 1 ]] || { echo "make_certs.sh: name at least one participant" >&2; exit 2; }
command -v openssl >/dev/null || { echo "make_certs.sh: needs openssl" >&2; exit 2; }
mkdir -p "$out"
cd "$out"
days=3650
if [[ ! -f ca.pem ]]; then
  openssl req -x509 -newkey rsa:2048 -nodes -keyout ca.key -out ca.pem -days "$days" \
    -subj "/CN=rosguard test CA/O=rosguard" 2>/dev/null
fi
sign() { openssl smime -sign -in "$1" -text -out "$2" -signer ca.pem -inkey ca.key; }
cat >governance.xml <<'XML'
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>230</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>NONE</rtps_protection_kind>
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
XML
sign governance.xml governance.p7s
for name in "$@"; do
  [[ $name =~ ^[A-Za-z0-9_-]+$ ]] || { echo "make_certs.sh: '$name' is not a plain name" >&2; exit 2; }
  openssl req -newkey rsa:2048 -nodes -keyout "$name.key" -out "$name.csr" \
    -subj "/CN=$name/O=rosguard" 2>/dev/null
  openssl x509 -req -in "$name.csr" -CA ca.pem -CAkey ca.key -CAcreateserial -out "$name.pem" \
    -days "$days" 2>/dev/null
  rm -f "$name.csr"
  cat >"permissions_$name.xml" <<XML
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$name">
      <subject_name>CN=$name,O=rosguard</subject_name>
      <validity><not_before>2020-01-01T00:00:00</not_before><not_after>2099-12-31T23:59:59</not_after></validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>230</max></id_range></domains>
        <publish><topics><topic>*</topic></topics></publish>
        <subscribe><topics><topic>*</topic></topics></subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
XML
  sign "permissions_$name.xml" "permissions_$name.p7s"
done
echo "wrote $out: ca.pem, governance.p7s and, for $*, NAME.pem, NAME.key, permissions_NAME.p7s"
