#include "densemap/msg/dds_security.h"

#include <chrono>
#include <ctime>
#include <filesystem>
#include <memory>

#include <fmt/format.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/pkcs7.h>
#include <openssl/x509.h>
#include <openssl/x509_vfy.h>
#include <openssl/x509v3.h>
#include <spdlog/spdlog.h>

#include "densemap/msg/dds_node.h"

namespace densemap::msg {

namespace {

namespace fs = std::filesystem;

template <auto F>
struct Free {
  template <class T>
  void operator()(T* p) const {
    F(p);
  }
};
using Bio = std::unique_ptr<BIO, Free<BIO_free_all>>;
using Cert = std::unique_ptr<X509, Free<X509_free>>;
using Crl = std::unique_ptr<X509_CRL, Free<X509_CRL_free>>;
using Key = std::unique_ptr<EVP_PKEY, Free<EVP_PKEY_free>>;
using Store = std::unique_ptr<X509_STORE, Free<X509_STORE_free>>;
using StoreCtx = std::unique_ptr<X509_STORE_CTX, Free<X509_STORE_CTX_free>>;
using Pkcs7 = std::unique_ptr<PKCS7, Free<PKCS7_free>>;

std::string opensslError() {
  const unsigned long e = ERR_get_error();
  ERR_clear_error();
  if (e == 0) return "no detail from OpenSSL";
  char buf[256];
  ERR_error_string_n(e, buf, sizeof buf);
  return buf;
}

Bio openFile(const fs::path& p) {
  Bio b(BIO_new_file(p.c_str(), "r"));
  if (!b) throw DdsError(fmt::format("cannot read {} ({})", p.string(), opensslError()));
  return b;
}

Cert readCertificate(const fs::path& p) {
  Bio b = openFile(p);
  Cert c(PEM_read_bio_X509(b.get(), nullptr, nullptr, nullptr));
  if (!c) throw DdsError(fmt::format("{} is not a PEM certificate ({})", p.string(), opensslError()));
  return c;
}

std::string utc(const ASN1_TIME* t) {
  std::tm tm{};
  if (ASN1_TIME_to_tm(t, &tm) != 1) return "?";
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S UTC", &tm);
  return buf;
}

std::int64_t unixTime(const ASN1_TIME* t) {
  std::tm tm{};
  if (ASN1_TIME_to_tm(t, &tm) != 1) return 0;
  return static_cast<std::int64_t>(timegm(&tm));
}

// The CA (and the revocation list, when there is one) as an OpenSSL store.
Store trustStore(const fs::path& ca_file, const fs::path& crl_file) {
  Store store(X509_STORE_new());
  Cert ca = readCertificate(ca_file);
  X509_STORE_add_cert(store.get(), ca.get());
  X509_STORE_set_purpose(store.get(), X509_PURPOSE_ANY);
  if (!crl_file.empty()) {
    Bio b = openFile(crl_file);
    Crl crl(PEM_read_bio_X509_CRL(b.get(), nullptr, nullptr, nullptr));
    if (!crl)
      throw DdsError(fmt::format("{} is not a PEM revocation list ({})", crl_file.string(), opensslError()));
    X509_STORE_add_crl(store.get(), crl.get());
    X509_STORE_set_flags(store.get(), X509_V_FLAG_CRL_CHECK);
  }
  return store;
}

void checkCertificate(const fs::path& dir, X509* cert, const fs::path& crl) {
  Store store = trustStore(dir / "identity_ca.cert.pem", crl);
  StoreCtx ctx(X509_STORE_CTX_new());
  X509_STORE_CTX_init(ctx.get(), store.get(), cert, nullptr);
  if (X509_verify_cert(ctx.get()) == 1) return;
  const int err = X509_STORE_CTX_get_error(ctx.get());
  const std::string where = (dir / "cert.pem").string();
  switch (err) {
    case X509_V_ERR_CERT_HAS_EXPIRED:
      throw DdsError(
          fmt::format("{} expired on {}: issue a new one (tools/make-security.sh KEYSTORE --add ...)", where,
                      utc(X509_get0_notAfter(cert))));
    case X509_V_ERR_CERT_NOT_YET_VALID:
      throw DdsError(fmt::format("{} is not valid before {} (is this host's clock right?)", where,
                                 utc(X509_get0_notBefore(cert))));
    case X509_V_ERR_CERT_REVOKED:
      throw DdsError(fmt::format("{} is revoked (crl.pem lists it): this identity may not join", where));
    case X509_V_ERR_UNABLE_TO_GET_ISSUER_CERT_LOCALLY:
    case X509_V_ERR_CERT_SIGNATURE_FAILURE:
    case X509_V_ERR_UNABLE_TO_VERIFY_LEAF_SIGNATURE:
      throw DdsError(
          fmt::format("{} is not signed by {}: the certificate and the CA come from different "
                      "keystores",
                      where, (dir / "identity_ca.cert.pem").string()));
    default:
      throw DdsError(fmt::format("{} does not verify against {}: {}", where,
                                 (dir / "identity_ca.cert.pem").string(),
                                 X509_verify_cert_error_string(err)));
  }
}

// governance.p7s and permissions.p7s: S/MIME signed by the permissions CA (Access-Permissions refuses
// them otherwise, with a less helpful message).
void checkSigned(const fs::path& dir, const char* file) {
  const fs::path p = dir / file;
  Bio in = openFile(p);
  BIO* content = nullptr;
  Pkcs7 p7(SMIME_read_PKCS7(in.get(), &content));
  Bio content_owner(content);
  if (!p7 || content == nullptr || !PKCS7_type_is_signed(p7.get()) || !PKCS7_get_detached(p7.get()))
    throw DdsError(fmt::format("{} is not an S/MIME signed document ({})", p.string(), opensslError()));
  Store store = trustStore(dir / "permissions_ca.cert.pem", {});
  Bio out(BIO_new(BIO_s_mem()));
  // The content behind a buffering BIO, not as the memory BIO it is: for a memory BIO OpenSSL 3.0's
  // PKCS7_verify makes a copy that it leaks when the structure is bad (found by fuzz_security_folder).
  Bio buffered(BIO_push(BIO_new(BIO_f_buffer()), content_owner.release()));
  if (PKCS7_verify(p7.get(), nullptr, store.get(), buffered.get(), out.get(), PKCS7_TEXT) != 1) {
    throw DdsError(
        fmt::format("{} does not verify against {} (changed after it was signed, or signed by another "
                    "CA): {}",
                    p.string(), (dir / "permissions_ca.cert.pem").string(), opensslError()));
  }
}

std::string fileUri(const fs::path& p) { return "file://" + p.string(); }

}  // namespace

SecurityIdentity checkSecurityFolder(const std::string& folder) {
  std::error_code ec;
  const fs::path dir = fs::absolute(folder, ec);
  if (ec || !fs::is_directory(dir)) {
    throw DdsError(
        fmt::format("--security-dir {}: no such folder (make one with tools/make-security.sh)", folder));
  }
  std::string missing;
  for (const char* f : kSecurityFiles) {
    if (!fs::is_regular_file(dir / f)) missing += std::string(missing.empty() ? "" : ", ") + f;
  }
  if (!missing.empty()) {
    throw DdsError(
        fmt::format("--security-dir {} lacks {}: an identity folder holds {} (tools/make-security.sh)",
                    dir.string(), missing,
                    "cert.pem, key.pem, identity_ca.cert.pem, permissions_ca.cert.pem, governance.p7s "
                    "and permissions.p7s"));
  }
  SecurityIdentity id;
  id.dir = dir.string();
  id.has_crl = fs::is_regular_file(dir / "crl.pem");
  Cert cert = readCertificate(dir / "cert.pem");
  {
    Bio b = openFile(dir / "key.pem");
    Key key(PEM_read_bio_PrivateKey(b.get(), nullptr, nullptr, nullptr));
    if (!key)
      throw DdsError(fmt::format("{} is not an unencrypted PEM private key", (dir / "key.pem").string()));
    if (X509_check_private_key(cert.get(), key.get()) != 1) {
      ERR_clear_error();
      throw DdsError(
          fmt::format("{} is not the key of {}", (dir / "key.pem").string(), (dir / "cert.pem").string()));
    }
  }
  checkCertificate(dir, cert.get(), id.has_crl ? dir / "crl.pem" : fs::path());
  checkSigned(dir, "governance.p7s");
  checkSigned(dir, "permissions.p7s");
  char cn[256] = {};
  if (X509_NAME_get_text_by_NID(X509_get_subject_name(cert.get()), NID_commonName, cn, sizeof cn) <= 0) {
    throw DdsError(fmt::format("{} has no common name (CN): the permissions name identities by it",
                               (dir / "cert.pem").string()));
  }
  id.name = cn;
  id.not_after_unix = unixTime(X509_get0_notAfter(cert.get()));
  return id;
}

void applySecurity(const SecurityIdentity& id, eprosima::fastdds::dds::DomainParticipantQos& qos) {
  const fs::path dir = id.dir;
  auto& props = qos.properties().properties();
  auto set = [&](const std::string& name, const std::string& value) { props.emplace_back(name, value); };
  const std::string auth = "dds.sec.auth.builtin.PKI-DH.";
  const std::string access = "dds.sec.access.builtin.Access-Permissions.";
  set("dds.sec.auth.plugin", "builtin.PKI-DH");
  set(auth + "identity_ca", fileUri(dir / "identity_ca.cert.pem"));
  set(auth + "identity_certificate", fileUri(dir / "cert.pem"));
  set(auth + "private_key", fileUri(dir / "key.pem"));
  if (id.has_crl) set(auth + "identity_crl", fileUri(dir / "crl.pem"));
  set("dds.sec.access.plugin", "builtin.Access-Permissions");
  set(access + "permissions_ca", fileUri(dir / "permissions_ca.cert.pem"));
  set(access + "governance", fileUri(dir / "governance.p7s"));
  set(access + "permissions", fileUri(dir / "permissions.p7s"));
  set("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
}

void logSecurity(const msg::DdsNode& node, const std::string& what) {
  if (!node.secure()) {
    spdlog::warn(
        "DDS-Security is off for the {}: unauthenticated and unencrypted, so any participant on this domain "
        "can send scans, read scans, replies and statistics, and issue commands. For authentication, access "
        "control and encryption: tools/make-security.sh KEYSTORE, then --security-dir KEYSTORE/server",
        what);
    return;
  }
  const auto& id = node.identity();
  const double days_left =
      static_cast<double>(id.not_after_unix - std::chrono::duration_cast<std::chrono::seconds>(
                                                  std::chrono::system_clock::now().time_since_epoch())
                                                  .count()) /
      86400.0;
  spdlog::info(
      "DDS-Security on for the {}: identity '{}' ({}), PKI-DH authentication, signed permissions, AES-GCM "
      "encryption; certificate valid for {:.0f} more days{}",
      what, id.name, id.dir, days_left, id.has_crl ? ", revocation list loaded" : ", no revocation list");
  if (days_left < 30) {
    spdlog::warn("the certificate in {} expires in {:.1f} days: issue a new one (README, 'Security')", id.dir,
                 days_left);
  }
}

}  // namespace densemap::msg
