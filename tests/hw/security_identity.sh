# identity_xml DIR NAME: a Cyclone configuration (CYCLONEDDS_URI) with the DDS Security identity
# NAME of the CA in DIR (docs/guard/security/make_certs.sh), on the loopback interface, as a
# ROS 2 program would take its identity. Needs $plugins: the directory of Cyclone's security
# plugins. Sourced by the security tests.
identity_xml() {
  cat <<XML
<CycloneDDS xmlns="https://cdds.io/config"><Domain Id="any">
  <General><Interfaces><NetworkInterface name="lo"/></Interfaces><AllowMulticast>false</AllowMulticast></General>
  <Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>60</MaxAutoParticipantIndex>
    <Peers><Peer address="127.0.0.1"/></Peers></Discovery>
  <Security>
    <Authentication>
      <Library path="$plugins/libdds_security_auth.so" initFunction="init_authentication" finalizeFunction="finalize_authentication"/>
      <IdentityCA>file:$1/ca.pem</IdentityCA>
      <IdentityCertificate>file:$1/$2.pem</IdentityCertificate>
      <PrivateKey>file:$1/$2.key</PrivateKey>
    </Authentication>
    <AccessControl>
      <Library path="$plugins/libdds_security_ac.so" initFunction="init_access_control" finalizeFunction="finalize_access_control"/>
      <PermissionsCA>file:$1/ca.pem</PermissionsCA>
      <Governance>file:$1/governance.p7s</Governance>
      <Permissions>file:$1/permissions_$2.p7s</Permissions>
    </AccessControl>
    <Cryptographic>
      <Library path="$plugins/libdds_security_crypto.so" initFunction="init_crypto" finalizeFunction="finalize_crypto"/>
    </Cryptographic>
  </Security>
</Domain></CycloneDDS>
XML
}
