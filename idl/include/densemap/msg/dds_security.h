// DDS-Security for a participant: one identity folder (tools/make-security.sh, or an SROS2 enclave) turned
// into Fast DDS 2.9's builtin plugins (PKI-DH, Access-Permissions, AES-GCM-GMAC). Checked before Fast DDS
// sees it, so a wrong folder is reported as what is wrong and what to do, not as a participant that fails.
#pragma once

#include <cstdint>
#include <string>

#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>

namespace densemap::msg {

/// The files of an identity folder, named as in an SROS2 enclave. crl.pem is optional.
inline constexpr const char* kSecurityFiles[] = {
    "cert.pem",       "key.pem",        "identity_ca.cert.pem", "permissions_ca.cert.pem",
    "governance.p7s", "permissions.p7s"};

struct SecurityIdentity {
  std::string dir;   ///< the folder, absolute
  std::string name;  ///< the certificate's common name: the identity's name (robot-1, client-2)
  std::int64_t not_after_unix = 0;  ///< when the certificate expires (seconds since 1970, UTC)
  bool has_crl = false;             ///< crl.pem present: revoked certificates are refused
};

/// Checks the folder: every file present, the certificate readable, valid now, and signed by
/// identity_ca.cert.pem, and not in crl.pem. Throws DdsError with what is wrong and what to do.
SecurityIdentity checkSecurityFolder(const std::string& dir);

/// Fast DDS's properties for the builtin plugins with this identity, added to the participant's QoS.
void applySecurity(const SecurityIdentity& identity, eprosima::fastdds::dds::DomainParticipantQos& qos);

class DdsNode;
/// Says in the log whether `node` is secure (its identity, its certificate's expiry) or, when plain, that
/// it is unauthenticated and what that allows. `what`: what the node serves ("densemap topics").
void logSecurity(const DdsNode& node, const std::string& what);

}  // namespace densemap::msg
