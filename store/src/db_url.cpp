#include "dentar/store/db_url.h"

#include <cctype>

namespace dentar::store {
namespace {

bool starts_with(std::string_view s, std::string_view p) { return s.substr(0, p.size()) == p; }

}  // namespace

Result<DbUrl> parse_db_url(std::string_view text) {
  DbUrl u;
  for (unsigned char c : text)
    if (c < 0x20 || c == 0x7f)
      return Error{"database URL: contains a control character; expected sqlite:PATH or postgresql://HOST/DB"};
  if (text.size() > 4096) return Error{"database URL: longer than 4096 characters"};
  if (starts_with(text, "sqlite:")) {
    std::string_view p = text.substr(7);
    if (starts_with(p, "//")) p = p.substr(2);  // sqlite://PATH is accepted too
    if (p.empty()) return Error{"database URL 'sqlite:': no file; expected sqlite:PATH (e.g. sqlite:school.db)"};
    u.kind = DbUrl::Kind::Sqlite;
    u.path = std::string(p);
    u.redacted = "sqlite:" + u.path;
    return u;
  }
  std::string_view rest;
  if (starts_with(text, "postgresql://")) rest = text.substr(13);
  else if (starts_with(text, "postgres://")) rest = text.substr(11);
  else {
    const std::string shown(text.substr(0, 80));
    return Error{"database URL '" + shown +
                 "': unknown kind; expected sqlite:PATH or postgresql://[USER[:PASSWORD]@]HOST[:PORT]/DBNAME"};
  }
  u.kind = DbUrl::Kind::Postgres;
  u.uri = std::string(text);
  // Redact a password: postgresql://user:secret@host -> postgresql://user:***@host
  const std::size_t slash = rest.find('/');
  const std::string_view authority = rest.substr(0, slash);
  const std::size_t at = authority.rfind('@');
  std::string red = std::string(text.substr(0, text.size() - rest.size()));
  std::string_view hostport = authority;
  if (at != std::string_view::npos) {
    const std::string_view userinfo = authority.substr(0, at);
    const std::size_t colon = userinfo.find(':');
    red += std::string(userinfo.substr(0, colon)) + (colon != std::string_view::npos ? ":***" : "") + "@";
    u.has_password = colon != std::string_view::npos;
    hostport = authority.substr(at + 1);
  }
  red += std::string(hostport);
  if (slash != std::string_view::npos) {
    std::string_view tail = rest.substr(slash);
    const std::size_t q = tail.find('?');
    red += std::string(tail.substr(0, q));
    if (q != std::string_view::npos) {
      red += "?...";
      const std::string_view query = tail.substr(q + 1);
      for (std::size_t s = 0; s <= query.size();) {
        std::size_t amp = query.find('&', s);
        if (amp == std::string_view::npos) amp = query.size();
        if (starts_with(query.substr(s, amp - s), "password=")) u.has_password = true;
        s = amp + 1;
      }
    }
  }
  u.redacted = red;
  // Port, when given, must be a number 1..65535 (IPv6 hosts are in brackets).
  std::string_view hp = hostport;
  if (starts_with(hp, "[")) {
    const std::size_t close = hp.find(']');
    if (close == std::string_view::npos) return Error{"database URL '" + red + "': unclosed '[' in the host"};
    hp = hp.substr(close + 1);
  }
  if (const std::size_t colon = hp.rfind(':'); colon != std::string_view::npos && hp.find(',') == std::string_view::npos) {
    const std::string_view port = hp.substr(colon + 1);
    long v = 0;
    bool ok = !port.empty() && port.size() <= 5;
    for (char c : port) {
      if (!std::isdigit(static_cast<unsigned char>(c))) ok = false;
      else v = v * 10 + (c - '0');
    }
    if (!ok || v < 1 || v > 65535)
      return Error{"database URL '" + red + "': port '" + std::string(port.substr(0, 16)) + "' must be 1-65535"};
  }
  return u;
}

std::string password_on_command_line(const DbUrl& url, const std::string& option) {
  if (!url.has_password) return "";
  return option + " " + url.redacted +
         ": a password on the command line shows in `ps` and in the shell's history; remove it from the URL and "
         "give it in the environment (PGPASSWORD=...) or in a pgpass file (~/.pgpass or $PGPASSFILE, mode 0600, "
         "lines HOST:PORT:DB:USER:PASSWORD)";
}

}  // namespace dentar::store
