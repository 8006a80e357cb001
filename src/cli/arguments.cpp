#include "arguments.hpp"

#include <cmath>
#include <cstdlib>

namespace demnerf::cli {

Arguments::Arguments(const std::vector<std::string>& tokens, const std::set<std::string>& flags) {
  for (std::size_t i = 0; i < tokens.size(); ++i) {
    const std::string& token = tokens[i];
    if (token.rfind("--", 0) != 0 || token.size() == 2) {
      throw UsageError("unexpected argument '" + token + "' (options look like --name value)");
    }
    std::string key = token.substr(2);
    const auto equals = key.find('=');
    if (equals != std::string::npos) {
      values_[key.substr(0, equals)] = key.substr(equals + 1);
    } else if (flags.count(key)) {
      values_[key] = "true";
    } else if (i + 1 < tokens.size()) {
      values_[key] = tokens[++i];
    } else {
      throw UsageError("option --" + key + " needs a value");
    }
  }
}

bool Arguments::has(const std::string& key) const { return values_.count(key) > 0; }

std::string Arguments::text(const std::string& key) const {
  const auto it = values_.find(key);
  if (it == values_.end()) throw UsageError("missing required option --" + key);
  return it->second;
}

std::string Arguments::text(const std::string& key, const std::string& fallback) const {
  const auto it = values_.find(key);
  return it == values_.end() ? fallback : it->second;
}

double Arguments::number(const std::string& key) const {
  const std::string value = text(key);
  char* end = nullptr;
  const double parsed = std::strtod(value.c_str(), &end);
  if (value.empty() || *end != '\0' || !std::isfinite(parsed)) {
    throw UsageError("option --" + key + " expects a number, got '" + value + "'");
  }
  return parsed;
}

double Arguments::number(const std::string& key, double fallback) const {
  return has(key) ? number(key) : fallback;
}

int Arguments::integer(const std::string& key, int fallback) const {
  if (!has(key)) return fallback;
  const std::string value = text(key);
  char* end = nullptr;
  const long parsed = std::strtol(value.c_str(), &end, 10);
  if (value.empty() || *end != '\0') {
    throw UsageError("option --" + key + " expects an integer, got '" + value + "'");
  }
  return static_cast<int>(parsed);
}

void Arguments::rejectUnknown(const std::set<std::string>& known) const {
  for (const auto& entry : values_) {
    if (!known.count(entry.first)) {
      throw UsageError("unknown option --" + entry.first + " (see --help)");
    }
  }
}

}  // namespace demnerf::cli
