#pragma once
// Command-line options of one `demnerf` subcommand: "--key value" pairs and "--flag"s.

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace demnerf::cli {

/// Bad usage: the message says which option is wrong and how to fix it; exit code 2.
class UsageError : public std::runtime_error {
 public:
  explicit UsageError(const std::string& message) : std::runtime_error(message) {}
};

class Arguments {
 public:
  /// Parses argv after the subcommand name. Options that take no value are listed in `flags`.
  Arguments(const std::vector<std::string>& tokens, const std::set<std::string>& flags);

  bool has(const std::string& key) const;
  bool flag(const std::string& key) const { return has(key); }
  std::string text(const std::string& key) const;  ///< required; UsageError when missing
  std::string text(const std::string& key, const std::string& fallback) const;
  double number(const std::string& key, double fallback) const;
  double number(const std::string& key) const;
  int integer(const std::string& key, int fallback) const;
  /// Throws UsageError naming the first option that is not in `known`.
  void rejectUnknown(const std::set<std::string>& known) const;

 private:
  std::map<std::string, std::string> values_;
};

}  // namespace demnerf::cli
