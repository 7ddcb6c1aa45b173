// The pre-scan of a deck's JSON text: what the JSON library would silently accept (a key given twice in one
// object, absurd nesting) is refused before anything is read.

#include <algorithm>
#include <set>
#include <string>
#include <vector>

#include "io/deck_parts.hpp"

namespace celldem::deck_json {

Json parse_json(const std::string& json_text) {
  int depth = 0, max_depth = 0;  // bounded before the parser's own recursion matters
  bool in_string = false, escaped = false;
  for (char c : json_text) {
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    else if (c == '{' || c == '[') max_depth = std::max(max_depth, ++depth);
    else if (c == '}' || c == ']') --depth;
  }
  if (max_depth > 64) throw DeckError("deck: nesting deeper than 64 levels");

  struct Frame {
    bool array = false;
    std::string path;
    std::set<std::string> keys;
    std::string key;
    std::size_t index = 0;
  };
  std::vector<Frame> frames;
  auto child_path = [&frames]() -> std::string {
    if (frames.empty()) return "";
    const Frame& f = frames.back();
    std::string path = f.path;
    if (f.array) {
      path += '[';
      path += std::to_string(f.index);
      path += ']';
    } else {
      path = key_path(path, f.key);
    }
    return path;
  };
  auto open = [&](bool array) {
    Frame f;
    f.array = array;
    f.path = child_path();
    frames.push_back(std::move(f));
  };
  auto element_done = [&frames] {
    if (!frames.empty() && frames.back().array) ++frames.back().index;
  };
  const Json::parser_callback_t track = [&](int, Json::parse_event_t event, Json& parsed) {
    using E = Json::parse_event_t;
    switch (event) {
      case E::object_start: open(false); break;
      case E::array_start: open(true); break;
      case E::key: {
        Frame& f = frames.back();
        f.key = parsed.get<std::string>();
        if (!f.keys.insert(f.key).second) fail(child_path(), "duplicate key (given more than once in one object)");
        break;
      }
      case E::object_end:
      case E::array_end:
        frames.pop_back();
        element_done();
        break;
      case E::value: element_done(); break;
    }
    return true;
  };
  try {
    return Json::parse(json_text, track, true, /*ignore_comments=*/true);
  } catch (const Json::exception& e) {  // parse errors, and numbers too large for a double
    throw DeckError(std::string("deck is not valid JSON: ") + e.what());
  }
}

}  // namespace celldem::deck_json
