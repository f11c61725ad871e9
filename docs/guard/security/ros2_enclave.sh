#!/usr/bin/env bash
# A ROS 2 security enclave from a participant of make_certs.sh: what a ROS 2 node (rclcpp with
# rmw_cyclonedds_cpp) needs to be heard by a `rosguard guard` or an hw run with DDS Security.
# ROS 2 reads its identity from a keystore, not from CYCLONEDDS_URI: with ROS_SECURITY_ENABLE=true
# and ROS_SECURITY_KEYSTORE=KEYSTORE, a node started with `--ros-args --enclave /NAME` (or
# ROS_SECURITY_ENCLAVE_OVERRIDE=/NAME) takes the six files of KEYSTORE/enclaves/NAME/ under
# their ROS 2 names. This script links them there (identity_ca.cert.pem, permissions_ca.cert.pem
# -> ca.pem; cert.pem, key.pem -> NAME.pem, NAME.key; governance.p7s; permissions.p7s ->
# permissions_NAME.p7s), so one CA serves the guard, rosguard's own programs and ROS 2 nodes.
# Usage: ros2_enclave.sh CERTS_DIR NAME KEYSTORE     e.g. ros2_enclave.sh /etc/rosguard/dds planner ~/keystore
set -euo pipefail
certs=$(cd "${1:?usage: ros2_enclave.sh CERTS_DIR NAME KEYSTORE}" && pwd)
name=${2:?usage: ros2_enclave.sh CERTS_DIR NAME KEYSTORE}
keystore=${3:?usage: ros2_enclave.sh CERTS_DIR NAME KEYSTORE}
for f in ca.pem "$name.pem" "$name.key" governance.p7s "permissions_$name.p7s"; do
  [[ -f $certs/$f ]] || { echo "ros2_enclave.sh: $certs/$f is missing (make_certs.sh $certs $name)" >&2; exit 2; }
done
enclave=$keystore/enclaves/$name
mkdir -p "$enclave"
ln -sf "$certs/ca.pem" "$enclave/identity_ca.cert.pem"
ln -sf "$certs/ca.pem" "$enclave/permissions_ca.cert.pem"
ln -sf "$certs/$name.pem" "$enclave/cert.pem"
ln -sf "$certs/$name.key" "$enclave/key.pem"
ln -sf "$certs/governance.p7s" "$enclave/governance.p7s"
ln -sf "$certs/permissions_$name.p7s" "$enclave/permissions.p7s"
echo "wrote $enclave: ROS_SECURITY_ENABLE=true ROS_SECURITY_KEYSTORE=$keystore, then --ros-args --enclave /$name"
