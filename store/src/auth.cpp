#include "dentar/store/auth.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>
#include <sys/stat.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace dentar::store {
namespace {

std::string hex(const std::string& b) {
  static const char* k = "0123456789abcdef";
  std::string s;
  for (unsigned char c : b) {
    s += k[c >> 4];
    s += k[c & 15];
  }
  return s;
}

bool unhex(std::string_view h, std::string& out) {
  if (h.size() % 2) return false;
  out.clear();
  auto v = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  for (std::size_t i = 0; i < h.size(); i += 2) {
    const int a = v(h[i]), b = v(h[i + 1]);
    if (a < 0 || b < 0) return false;
    out += static_cast<char>(a * 16 + b);
  }
  return true;
}

std::string derive(const std::string& password, const std::string& salt, int iterations, std::size_t bytes) {
  std::string key(bytes, '\0');
  if (PKCS5_PBKDF2_HMAC(password.data(), static_cast<int>(password.size()),
                        reinterpret_cast<const unsigned char*>(salt.data()), static_cast<int>(salt.size()), iterations,
                        EVP_sha256(), static_cast<int>(bytes), reinterpret_cast<unsigned char*>(key.data())) != 1)
    throw std::runtime_error("PBKDF2 failed");
  return key;
}

}  // namespace

std::string random_token_hex(std::size_t bytes) {
  std::string b(bytes, '\0');
  if (RAND_bytes(reinterpret_cast<unsigned char*>(b.data()), static_cast<int>(bytes)) != 1)
    throw std::runtime_error("RAND_bytes failed");
  return hex(b);
}

Result<PasswordFile> parse_password_file(std::string_view text) {
  PasswordFile f;
  std::size_t line_no = 0, pos = 0;
  if (text.size() > (1u << 20)) return Error{"password file: larger than 1 MiB"};
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const std::string ln = "line " + std::to_string(line_no) + ": ";
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string_view> parts;
    for (std::size_t s = 0;;) {
      const std::size_t c = line.find(':', s);
      parts.push_back(line.substr(s, c == std::string_view::npos ? std::string_view::npos : c - s));
      if (c == std::string_view::npos) break;
      s = c + 1;
    }
    if (parts.size() != 5) return Error{ln + "expected NAME:pbkdf2-sha256:ITERATIONS:SALT_HEX:HASH_HEX (5 fields), got " + std::to_string(parts.size())};
    const std::string name(parts[0]);
    if (name.empty() || name.size() > 64) return Error{ln + "user name must be 1-64 characters"};
    for (unsigned char c : name)
      if (c <= 0x20 || c == 0x7f) return Error{ln + "user name contains a space or control character"};
    if (parts[1] != "pbkdf2-sha256") return Error{ln + "scheme '" + std::string(parts[1].substr(0, 32)) + "' unknown; expected pbkdf2-sha256"};
    PasswordEntry e;
    long long it = 0;
    const std::string range = std::to_string(kMinPbkdf2Iterations) + "-100000000";
    if (parts[2].empty() || parts[2].size() > 9) return Error{ln + "field 3 (iterations) must be a number " + range};
    for (char c : parts[2]) {
      if (c < '0' || c > '9') return Error{ln + "field 3 (iterations) '" + std::string(parts[2]) + "' is not a number"};
      it = it * 10 + (c - '0');
    }
    if (it < kMinPbkdf2Iterations)
      return Error{ln + "field 3 (iterations) is " + std::to_string(it) + ", fewer than " +
                   std::to_string(kMinPbkdf2Iterations) + " PBKDF2 iterations are too quick to guess through; set the "
                   "password again with `dentar serve --passwords FILE --set-password " + name + "`"};
    if (it > 100000000) return Error{ln + "field 3 (iterations) must be " + range};
    e.iterations = static_cast<int>(it);
    if (!unhex(parts[3], e.salt) || e.salt.size() < 8 || e.salt.size() > 64)
      return Error{ln + "salt must be 16-128 hex digits"};
    if (!unhex(parts[4], e.hash) || e.hash.size() < 16 || e.hash.size() > 64)
      return Error{ln + "hash must be 32-128 hex digits"};
    if (f.count(name)) return Error{ln + "user '" + name + "' appears twice"};
    f[name] = e;
  }
  return f;
}

Result<PasswordFile> load_password_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Error{path + ": cannot read the password file; create it with `dentar serve --passwords " + path + " --set-password USER`"};
  std::ostringstream s;
  s << in.rdbuf();
  auto f = parse_password_file(s.str());
  if (!f) return Error{path + ": " + f.error()};
  return f;
}

std::string format_password_file(const PasswordFile& f) {
  std::string out = "# DentAR instructor logins: NAME:pbkdf2-sha256:ITERATIONS:SALT_HEX:HASH_HEX\n";
  for (const auto& [name, e] : f)
    out += name + ":pbkdf2-sha256:" + std::to_string(e.iterations) + ":" + hex(e.salt) + ":" + hex(e.hash) + "\n";
  return out;
}

PasswordEntry hash_password(const std::string& password, int iterations) {
  PasswordEntry e;
  e.iterations = iterations;
  e.salt.resize(16);
  if (RAND_bytes(reinterpret_cast<unsigned char*>(e.salt.data()), 16) != 1) throw std::runtime_error("RAND_bytes failed");
  e.hash = derive(password, e.salt, iterations, 32);
  return e;
}

bool verify_password(const PasswordEntry& e, const std::string& password) {
  if (e.hash.empty()) return false;
  const std::string k = derive(password, e.salt, e.iterations, e.hash.size());
  return CRYPTO_memcmp(k.data(), e.hash.data(), k.size()) == 0;
}

Status set_password(const std::string& path, const std::string& user, const std::string& password, int iterations) {
  namespace fs = std::filesystem;
  PasswordFile f;
  std::error_code ec;
  if (fs::exists(path, ec)) {
    auto old = load_password_file(path);
    if (!old) return Error{old.error()};
    f = *old;
  }
  if (user.empty() || user.size() > 64 || user.find(':') != std::string::npos)
    return Error{"user name '" + user + "': must be 1-64 characters without ':'"};
  for (unsigned char c : user)
    if (c <= 0x20 || c == 0x7f) return Error{"user name: contains a space or control character"};
  if (password.size() < kMinPasswordLength)
    return Error{"password: " + std::to_string(password.size()) + " characters, at least " +
                 std::to_string(kMinPasswordLength) + " are needed (a passphrase of several words is easiest)"};
  if (iterations < kMinPbkdf2Iterations || iterations > 100000000)
    return Error{"iterations " + std::to_string(iterations) + ": must be " + std::to_string(kMinPbkdf2Iterations) +
                 "-100000000"};
  f[user] = hash_password(password, iterations);
  const std::string tmp = path + ".tmp";
  {
    const mode_t old = umask(077);  // readable by the owner only
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    umask(old);
    if (!out) return Error{tmp + ": cannot write"};
    out << format_password_file(f);
    if (!out.flush()) return Error{tmp + ": write failed"};
  }
  fs::rename(tmp, path, ec);
  if (ec) return Error{path + ": cannot replace: " + ec.message()};
  return {};
}

}  // namespace dentar::store
