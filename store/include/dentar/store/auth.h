// Instructor logins: a password file, one user a line,
//   name:pbkdf2-sha256:ITERATIONS:SALT_HEX:HASH_HEX
// ('#' comments and blank lines allowed), hashed with OpenSSL's PBKDF2-HMAC-
// SHA256 (600,000 iterations by default, at least 100,000; 16-byte random
// salt, 32-byte key).
#pragma once

#include <map>
#include <string>
#include <string_view>

#include "dentar/core/result.h"

namespace dentar::store {

struct PasswordEntry {
  int iterations = 0;
  std::string salt, hash;  // raw bytes
};

constexpr int kDefaultPbkdf2Iterations = 600000;
// The password file refuses fewer iterations (naming the line and field), and
// set_password refuses shorter passwords (application security standards ask
// 12 characters for a password-only login).
constexpr int kMinPbkdf2Iterations = 100000;
constexpr std::size_t kMinPasswordLength = 12;

using PasswordFile = std::map<std::string, PasswordEntry>;

// Errors name the line and the field ("line 3: iterations 'x' ...").
Result<PasswordFile> parse_password_file(std::string_view text);
Result<PasswordFile> load_password_file(const std::string& path);
std::string format_password_file(const PasswordFile& f);

PasswordEntry hash_password(const std::string& password, int iterations = kDefaultPbkdf2Iterations);
// Constant-time comparison of the derived key.
bool verify_password(const PasswordEntry& e, const std::string& password);

// Adds or replaces a user in the file (created 0600 if missing); written
// through a temporary file and a rename.
Status set_password(const std::string& path, const std::string& user, const std::string& password,
                    int iterations = kDefaultPbkdf2Iterations);

std::string random_token_hex(std::size_t bytes);

}  // namespace dentar::store
