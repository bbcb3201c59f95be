// SPDX-License-Identifier: MIT
// somm — Wavefront OBJ/MTL loading via tinyobjloader.
//
// Geometries: one per (shape, material) in order of first appearance, triangles in file order, polygons
// fanned (v0, vk, vk+1). The alpha mask of a material: map_d (by -imfchan: m or none = the alpha channel when
// the image has one, else the luminance; l = luminance; r/g/b = that channel), else the alpha channel of
// map_Kd when it has one, else none (opaque; the dissolve `d` is ignored). Textures repeat unless `-clamp
// on`; filter linear; cutoff 0.5. OBJ's v = 0 is the bottom image row, so image rows are flipped on load and
// UVs are kept as they are.
#include <tbb/parallel_for.h>
#include <tbb/task_group.h>
#include <tiny_obj_loader.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>

#include "image_io.h"
#include "loaders.h"
#include "somm/io.h"

namespace somm::detail {

namespace {

// Face, line and point indices must fit tinyobjloader's int (it overflows silently): in a line whose first token
// (after spaces and tabs) is f, l or p followed by a space or tab, every run of digits must be ≤ 2^31 − 1. The check
// runs on the bytes as they stream to the parser (IndexScan::feed per chunk), so what is parsed is what was checked.
//
// With `strict` (the UV-only load, loadObjUvOnly) it also tells, in irregular(), whether the file uses anything
// that tinyobjloader's callback parser reads differently from LoadObj: line (l) or point (p) elements, skin
// weight (vw) lines, a line starting with "usemtl" not followed by a space or tab, or a face (f) line that is not
// 1+ tokens of the strict forms v, v/t, v//n, v/t/n (each an optional '-' and digits, value not 0) separated by
// spaces or tabs. On such files the caller loads the full way instead. Lines end at LF, CR or CR LF, as the parsers
// read them (line() counts LFs).
class IndexScan {
 public:
  explicit IndexScan(bool strict = false) : strict_(strict) {}
  // Scans bytes [p, p + n); false at the first out-of-range index (line() and token() tell which). Strict: what the
  // parser need not read is dropped from the bytes (compacted in place: `kept` is their new length) — position
  // lines with surely finite numbers (position()), texture coordinate lines read here (texcoord()), the numbers of
  // normal lines (elideNormal()) and strict face lines read here (takeFace(): the first of a run keeps "f 0").
  bool feed(char* p, size_t n, size_t& kept) {
    drops_.clear();
    compactQueues();
    openAt_ = SIZE_MAX;  // a run of faces never goes on into another chunk
    if (!scan(p, n)) return false;
    kept = n;
    if (drops_.empty()) return true;
    size_t w = drops_[0].first;
    for (size_t k = 0; k < drops_.size(); ++k) {
      const size_t from = drops_[k].second, to = k + 1 < drops_.size() ? drops_[k + 1].first : n;
      std::memmove(p + w, p + from, to - from);
      w += to - from;
    }
    kept = w;
    return true;
  }
  // The end of the file: false when it ends inside an out-of-range index.
  bool finish() {
    if (strict_ && phase_ == kFace && lead_ == 'f') {
      strictFace(face_, '\n');
      irregular_ = irregular_ || face_.irregular;
    }
    if (phase_ == kSkip && word_ != 0) usemtlWord('\n');
    return phase_ != kFace || finishNumber();
  }
  size_t line() const { return line_; }
  std::string token() const { return std::string(token_, tokenLength_); }
  bool irregular() const { return irregular_; }
  // What the parser's next face callback stands for (strict), in file order: a batch of `faces` faces read here
  // (takeFace: the parser met "f 0"; nextFace hands them out), or with faces = 0 an f line the parser read itself,
  // when `positions` position lines preceded it. False when there is none.
  struct FaceCall {
    uint32_t faces = 0;
    uint64_t positions = 0, texcoords = 0;
  };
  bool nextCall(FaceCall& call) {
    if (callHead_ == calls_.size()) return false;
    call = calls_[callHead_++];
    return true;
  }
  // The next face of a batch: its vertices, their count and the numbers of position and texture coordinate lines
  // before it.
  bool nextFace(const tinyobj::index_t*& ix, int& count, uint64_t& positions, uint64_t& texcoords) {
    if (faceHead_ == faces_.size()) return false;
    const QueuedFace& f = faces_[faceHead_++];
    ix = faceIndices_.data() + f.first;
    count = int(f.count);
    positions = f.positions;
    texcoords = f.texcoords;
    return true;
  }
  // The texture coordinates (u, v per line, in file order): the scan stores those it reads and reserves the places
  // of those the parser reads (nextKeptTexcoord). Strict; without it the parser reads every texture coordinate line.
  void setTexcoords(std::vector<float>* uv) { texcoords_ = uv; }
  // The number (from 0) of the texture coordinate line the parser's next texture coordinate callback comes from.
  bool nextKeptTexcoord(uint64_t& index) {
    if (keptUvHead_ == keptTexcoords_.size()) return false;
    index = keptTexcoords_[keptUvHead_++];
    return true;
  }
  // The number (from 0) of the position line the parser's next vertex callback comes from (positions whose line the
  // scan dropped make no callback).
  bool nextKeptPosition(uint64_t& index) {
    if (keptHead_ == keptPositions_.size()) return false;
    index = keptPositions_[keptHead_++];
    return true;
  }

 private:
  bool scan(char* p, size_t n) {
    for (size_t i = 0; i < n; ++i) {
      const char c = p[i];
      switch (phase_) {
        case kLead:
          if (c == '\n') {
            ++line_;
          } else if (c != ' ' && c != '\t' && c != '\r') {
            phase_ = (c == 'f' || c == 'l' || c == 'p') ? kCandidate : kSkip;
            lead_ = c;
            word_ = strict_ && c == 'u' ? 1u : 0u;
            vw_ = strict_ && c == 'v' ? 1u : 0u;
          }
          break;
        case kCandidate:
          if (c == '\n' || c == '\r') {
            line_ += c == '\n';
            phase_ = kLead;
          } else if (c == ' ' || c == '\t') {
            phase_ = kFace;
            if (strict_ && lead_ != 'f') irregular_ = true;
            face_ = FaceState{};
            if (strict_ && lead_ == 'f') {
              const size_t e = takeFace(p, i, n);
              if (e != 0) {
                phase_ = kLead, i = e - 1;  // on at the line's end (LF or CR)
              } else {
                calls_.push_back(FaceCall{0, positions_, texcoordCount()});  // the parser reads this line
              }
            }
          } else {
            phase_ = kSkip;
          }
          break;
        case kFace: {
          // The rest of the line within these bytes, with the state in locals (the compiler must otherwise assume
          // that the bytes alias the members).
          const bool strict = strict_ && lead_ == 'f';
          FaceState f = face_;
          bool inNumber = inNumber_;
          uint64_t value = value_;
          uint32_t length = tokenLength_;
          bool ok = true;
          size_t j = i;
          for (; j < n; ++j) {
            const char d = p[j];
            if (strict) strictFace(f, d);
            if (d >= '0' && d <= '9') {
              if (!inNumber) inNumber = true, value = 0, length = 0;
              if (value <= 0x7FFFFFFFu) value = value * 10 + uint64_t(d - '0');
              if (length < sizeof token_) token_[length++] = d;
            } else {
              if (inNumber) {
                inNumber = false;
                if (value > 0x7FFFFFFFu) {
                  ok = false;
                  break;
                }
              }
              if (d == '\n' || d == '\r') break;
            }
          }
          face_ = f;
          irregular_ = irregular_ || f.irregular;  // sticky: face_ starts afresh on the next f line
          inNumber_ = inNumber;
          value_ = value;
          tokenLength_ = length;
          if (!ok) return false;
          if (j < n) line_ += p[j] == '\n', phase_ = kLead;  // stopped at the line's end
          i = j;
          break;
        }
        case kSkip:
          if (word_ != 0) usemtlWord(c);
          // "vw" then a space or tab: a skin weight line (LoadObj may fail on it); "v", "vn", "vt" then one: position(),
          // elideNormal(), texcoord().
          if (vw_ != 0) {
            const bool space = c == ' ' || c == '\t';
            if (vw_ == 2 && space) irregular_ = true;
            if (space && vw_ == 1) position(p, i, n);
            if (space && vw_ == 3) elideNormal(p, i + 1, n);
            if (space && vw_ == 4) texcoord(p, i, n);
            vw_ = vw_ != 1 ? 0u : c == 'w' ? 2u : c == 'n' ? 3u : c == 't' ? 4u : 0u;
          }
          if (c == '\n' || c == '\r') {
            line_ += c == '\n';
            phase_ = kLead;
          } else if (word_ == 0 &&
                     vw_ == 0) {  // nothing more to check on this line: on to its end (LF or CR)
            const char* end = lineEnd(p, i + 1, n);
            if (end == p + n) return true;
            i = size_t(end - p);
            line_ += *end == '\n';
            phase_ = kLead;
          }
          break;
      }
    }
    return true;
  }
  // The first LF or CR in bytes [from, n) (a line ends at either), or p + n.
  static const char* lineEnd(const char* p, size_t from, size_t n) {
    const char* nl = static_cast<const char*>(std::memchr(p + from, '\n', n - from));
    const char* e = nl ? nl : p + n;
    const char* cr = static_cast<const char*>(std::memchr(p + from, '\r', size_t(e - (p + from))));
    return cr ? cr : e;
  }
  // The length of the line end at e (< p + n): CR LF within these bytes is 2, else 1.
  static size_t endLength(const char* p, const char* e, size_t n) {
    return *e == '\r' && e + 1 < p + n && e[1] == '\n' ? 2 : 1;
  }
  // An f line whose body, bytes [at + 1, end of line) (`at`: the blank after "f"), lies in these bytes and is 1+
  // tokens of the strict forms (each field an optional '-' and 1-9 digits, not all 0 — no overflow, and the values
  // tinyobjloader's atoi gives) is read here and queued for nextFace. The first of a run of such lines with nothing
  // else between them (but position lines dropped whole, see position()) within these bytes keeps "f 0" (the parser
  // reads one vertex of index 0, which no strict face has: its callback takes the whole run, nextCall); the others
  // are dropped whole. Returns the line end's position, or 0 when the line is left to the character scan (and the
  // parser): another form, or a line that goes on beyond these bytes.
  size_t takeFace(char* p, size_t at, size_t n) {
    const size_t from = at + 1;
    const char* b = p + from;
    const char* e = lineEnd(p, from, n);
    if (e == p + n) return 0;
    const size_t first = faceIndices_.size();
    uint32_t count = 0;
    const char* q = b;
    for (;;) {
      while (q != e && (*q == ' ' || *q == '\t')) ++q;
      if (q == e) break;
      int32_t f[3] = {0, 0, 0};
      for (int field = 0;; ++field) {
        const bool negative = *q == '-';
        q += negative;
        const char* d = q;
        // The digits (the line end at e stops the loop); more than 9: left to the character scan below (v may
        // wrap then, unsigned).
        uint64_t v = 0;
        while (uint8_t(*q - '0') < 10) v = v * 10 + uint64_t(*q++ - '0');
        if (q == d) {  // an empty field: only the middle one of v//n
          if (negative || field != 1 || q == e || *q != '/') return faceIndices_.resize(first), 0;
        } else if (q - d > 9 || v == 0) {
          return faceIndices_.resize(first), 0;
        }
        f[field] = negative ? -int32_t(v) : int32_t(v);
        if (q == e || *q != '/') break;
        if (field == 2) return faceIndices_.resize(first), 0;
        ++q;
      }
      if (q != e && *q != ' ' && *q != '\t') return faceIndices_.resize(first), 0;
      tinyobj::index_t ix;
      ix.vertex_index = f[0];
      ix.texcoord_index = f[1];
      ix.normal_index = f[2];
      faceIndices_.push_back(ix);
      ++count;
    }
    if (count == 0) return 0;
    faces_.push_back(QueuedFace{first, count, positions_, texcoordCount()});
    const size_t end = size_t(e - p);
    if (at >= 1 && at - 1 == openAt_) {  // the run goes on: the whole line goes
      ++calls_.back().faces;
      dropLine(p, at - 1, e, n);
    } else {
      calls_.push_back(FaceCall{1, 0, 0});
      p[from] = '0';
      if (end > from + 1) drops_.emplace_back(from + 1, end);
      openAt_ = end + endLength(p, e, n);
    }
    return end;
  }
  // Drops the line [start, e] with its line end (e < p + n: LF, CR or CR LF); one that starts where the last run of
  // faces ends (openAt_) lets the run go on past it.
  void dropLine(const char* p, size_t start, const char* e, size_t n) {
    const size_t next = size_t(e - p) + endLength(p, e, n);
    drops_.emplace_back(start, next);
    if (start == openAt_) openAt_ = next;
  }
  // A position (v) line (strict; `at`: the blank after "v"). A position is read for the finiteness of x, y, z
  // (nonFinite), so it is left out only when its numbers are surely finite (finiteNumbers) and the line ends in
  // these bytes: then the whole line goes (the parser makes no callback for it), or — its "v" in the previous
  // chunk — its numbers go (the parser reads "v " as (0, 0, 0), finite too). Otherwise the parser reads it whole.
  // A line the parser reads has its number queued for nextKeptPosition.
  void position(char* p, size_t at, size_t n) {
    const char* e = lineEnd(p, at + 1, n);
    const bool finite = e != p + n && finiteNumbers(p + at + 1, e);
    if (finite && at >= 1) {
      dropLine(p, at - 1, e, n);
    } else {
      keptPositions_.push_back(positions_);
      if (finite && e != p + at + 1) drops_.emplace_back(at + 1, size_t(e - p));
    }
    ++positions_;
  }
  uint64_t texcoordCount() const { return texcoords_ ? texcoords_->size() / 2 : 0; }
  // A texture coordinate (vt) line (strict; `at`: the blank after "vt"). Read here when it lies in these bytes and
  // its first two numbers (what the parser's callback passes on; the rest of the line is never used) are each empty
  // or of the form [+-](digits[.digits] | digits. | .digits)[(e|E)[+-]digits], at most 3 exponent digits: their
  // values are those of tinyobjloader's parseReal (readNumber), and the whole line goes. Otherwise the parser reads
  // it into the place reserved here.
  void texcoord(char* p, size_t at, size_t n) {
    if (!texcoords_) return;
    const char* e = lineEnd(p, at + 1, n);
    float uv[2] = {0.0f, 0.0f};
    bool read = at >= 2 && e != p + n;
    const char* q = p + at + 1;
    for (int k = 0; k < 2 && read; ++k) {
      while (q != e && (*q == ' ' || *q == '\t')) ++q;
      double value = 0.0;
      if (q != e) q = readNumber(q, e, value);
      read = q != nullptr && (q == e || *q == ' ' || *q == '\t');  // the number is the whole token
      uv[k] = float(value);
    }
    texcoords_->insert(texcoords_->end(), uv, uv + 2);
    if (read) {
      dropLine(p, at - 2, e, n);
    } else {
      keptTexcoords_.push_back(texcoordCount() - 1);
    }
  }
  // A number of the form above at b (before e), with the arithmetic of tinyobjloader's tryParseDouble (the same
  // double operations in the same order: the digits accumulated, the fraction digits' weights from a table of 10^-k
  // up to k = 7 and pow(10, -k) beyond, the exponent as ldexp(m * pow(5, x), x), the sign applied last). Returns
  // where it ends, or nullptr when the bytes at b do not start with that form.
  static const char* readNumber(const char* b, const char* e, double& value) {
    const char* q = b;
    const bool negative = q != e && *q == '-';
    if (q != e && (*q == '+' || *q == '-')) ++q;
    double m = 0.0;
    const char* digits = q;
    for (; q != e && *q >= '0' && *q <= '9'; ++q) m = m * 10 + double(*q - '0');
    bool any = q != digits;
    if (q != e && *q == '.') {
      static const double kTenths[] = {1.0, 0.1, 0.01, 0.001, 0.0001, 0.00001, 0.000001, 0.0000001};
      ++q;
      int k = 1;
      for (; q != e && *q >= '0' && *q <= '9'; ++q, ++k) {
        const double w = k < 8 ? kTenths[k] : std::pow(10.0, -k);
        m += double(*q - '0') * w;
        any = true;
      }
    }
    if (!any) return nullptr;  // no digit before or after the point
    int exponent = 0;
    if (q != e && (*q == 'e' || *q == 'E')) {
      ++q;
      const bool negativeExp = q != e && *q == '-';
      if (q != e && (*q == '+' || *q == '-')) ++q;
      const char* d = q;
      for (; q != e && *q >= '0' && *q <= '9'; ++q)
        if (q - d < 3) exponent = exponent * 10 + (*q - '0');  // more digits: not read here (no overflow)
      if (q == d || q - d > 3) return nullptr;
      if (negativeExp) exponent = -exponent;
    }
    value = (negative ? -1 : 1) * (exponent != 0 ? std::ldexp(m * std::pow(5.0, exponent), exponent) : m);
    return q;
  }
  // Drops what the parser has taken from the queues (what is left: at most a line that crossed the last chunk's end).
  void compactQueues() {
    if (callHead_ != 0) calls_.erase(calls_.begin(), calls_.begin() + ptrdiff_t(callHead_)), callHead_ = 0;
    if (keptHead_ != 0)
      keptPositions_.erase(keptPositions_.begin(), keptPositions_.begin() + ptrdiff_t(keptHead_)),
          keptHead_ = 0;
    if (keptUvHead_ != 0)
      keptTexcoords_.erase(keptTexcoords_.begin(), keptTexcoords_.begin() + ptrdiff_t(keptUvHead_)),
          keptUvHead_ = 0;
    if (faceHead_ == 0) return;
    const size_t firstLeft = faceHead_ < faces_.size() ? faces_[faceHead_].first : faceIndices_.size();
    faces_.erase(faces_.begin(), faces_.begin() + ptrdiff_t(faceHead_)), faceHead_ = 0;
    faceIndices_.erase(faceIndices_.begin(), faceIndices_.begin() + ptrdiff_t(firstLeft));
    for (QueuedFace& f : faces_) f.first -= firstLeft;
  }
  // A normal (vn) line's numbers, bytes [from, end of line) (strict only): a normal is only counted (UvParse), so
  // they go and the parser reads "vn ". Not when the line ends beyond these bytes (it stays whole).
  void elideNormal(const char* p, size_t from, size_t n) {
    const char* e = lineEnd(p, from, n);
    if (e != p + n && e != p + from) drops_.emplace_back(from, size_t(e - p));
  }
  // Whether a position line's numbers [p, end) are surely finite: every token of the form [+-](digits[.digits] |
  // .digits)[(e|E)(+digits | -digits)], at most 15 integer digits, a positive exponent of one digit and a negative
  // one of at most 3 (below 10^24: finite as float).
  static bool finiteNumbers(const char* p, const char* end) {
    // Most files: digits, '.', '-', '+', spaces and tabs only, no run of more than 15 digits — whatever the parser
    // makes of such tokens is below 10^15 (no exponent). Otherwise the token grammar below.
    unsigned run = 0;
    for (const char* q = p; q != end; ++q) {
      const char c = *q;
      if (c >= '0' && c <= '9') {
        if (++run > 15) return finiteTokens(p, end);
      } else if (c == '.' || c == ' ' || c == '-' || c == '\t' || c == '+') {
        run = 0;
      } else {
        return finiteTokens(p, end);
      }
    }
    return true;
  }
  static bool finiteTokens(const char* p, const char* end) {
    enum { kGap, kSign, kInt, kDot, kFrac, kExp, kExpSign, kExpDigits };
    int state = kGap;
    unsigned count = 0;  // integer digits / exponent digits so far
    bool negativeExp = false;
    for (; p != end; ++p) {
      const char c = *p;
      const bool digit = c >= '0' && c <= '9';
      if (c == ' ' || c == '\t') {
        if (state == kSign || state == kDot || state == kExp || state == kExpSign) return false;
        state = kGap;
        continue;
      }
      switch (state) {
        case kGap:
        case kSign:
          if (digit) {
            state = kInt, count = 1;
          } else if (c == '.') {
            state = kDot;
          } else if (state == kGap && (c == '+' || c == '-')) {
            state = kSign;
          } else {
            return false;
          }
          break;
        case kInt:
          if (digit) {
            if (++count > 15) return false;
          } else if (c == '.') {
            state = kFrac;
          } else if (c == 'e' || c == 'E') {
            state = kExp;
          } else {
            return false;
          }
          break;
        case kDot:  // a leading '.': a digit must follow
          if (!digit) return false;
          state = kFrac;
          break;
        case kFrac:
          if (c == 'e' || c == 'E') {
            state = kExp;
          } else if (!digit) {
            return false;
          }
          break;
        case kExp:
        case kExpSign:
          if (digit) {
            negativeExp = state == kExpSign && negativeExp;
            state = kExpDigits, count = 1;
          } else if (state == kExp && (c == '+' || c == '-')) {
            state = kExpSign, negativeExp = c == '-';
          } else {
            return false;
          }
          break;
        default:  // kExpDigits
          if (!digit || ++count > (negativeExp ? 3u : 1u)) return false;
          break;
      }
    }
    return !(state == kSign || state == kDot || state == kExp || state == kExpSign);
  }
  enum Phase { kLead, kCandidate, kFace, kSkip };
  // The strict check of an f line: the token being read and its field (number `slashes`: v, t, n).
  struct FaceState {
    uint32_t fieldChars = 0, tokens = 0, slashes = 0;
    bool inToken = false, sign = false, nonzero = false, irregular = false;
  };
  bool finishNumber() {
    if (!inNumber_) return true;
    inNumber_ = false;
    return value_ <= 0x7FFFFFFFu;
  }
  // A line whose first character was lead_ == 'u': word_ characters of "usemtl" matched so far (0: not that word).
  void usemtlWord(char c) {
    static const char kWord[] = "usemtl";
    if (word_ < 6) {
      word_ = c == kWord[word_] ? word_ + 1 : 0;
    } else {
      if (c != ' ' && c != '\t') irregular_ = true;  // "usemtl" then something else: LoadObj still reads it
      word_ = 0;
    }
  }
  // One character of an f line's body (after "f "), strict forms only.
  static void strictFace(FaceState& f, char c) {
    const bool end = c == '\n' || c == '\r';  // the parsers end a line at LF, CR or CR LF
    if (c == ' ' || c == '\t' || end) {
      if (f.inToken) {
        endField(f, false);
        f.inToken = false;
        ++f.tokens;
      }
      if (end && f.tokens == 0) f.irregular = true;  // a face without indices
      return;
    }
    if (!f.inToken) f.inToken = true, f.fieldChars = 0, f.sign = false, f.nonzero = false, f.slashes = 0;
    if (c == '/') {
      endField(f, true);
      ++f.slashes;
      if (f.slashes > 2) f.irregular = true;
      f.fieldChars = 0, f.sign = false, f.nonzero = false;
    } else if (c == '-' && f.fieldChars == 0 && !f.sign) {
      f.sign = true;
    } else if (c >= '0' && c <= '9') {
      ++f.fieldChars;
      f.nonzero = f.nonzero || c != '0';
    } else {
      f.irregular = true;
    }
  }
  // The field that ends here (`slash`: a '/' follows): empty only as the middle field of v//n.
  static void endField(FaceState& f, bool slash) {
    if (f.fieldChars == 0) {
      if (f.sign || !(f.slashes == 1 && slash)) f.irregular = true;
    } else if (!f.nonzero) {
      f.irregular = true;
    }
  }
  bool strict_;
  bool irregular_ = false;
  Phase phase_ = kLead;
  char lead_ = 0;
  uint32_t word_ = 0;
  // A line whose first character was 'v' (strict): 1, then 2 after "vw", 3 after "vn", 4 after "vt" (0: none).
  uint32_t vw_ = 0;
  FaceState face_;
  size_t line_ = 1;
  bool inNumber_ = false;
  uint64_t value_ = 0;
  char token_[40] = {};  // the digits of the last number (the first 40)
  uint32_t tokenLength_ = 0;
  std::vector<std::pair<size_t, size_t>> drops_;  // byte ranges feed() removes
  uint64_t positions_ = 0;                        // position lines so far (strict)
  size_t openAt_ = SIZE_MAX;  // where in these bytes a line must start to join the last run of faces
  // The faces takeFace read and the parser has not reached yet: their vertices, and per face its first vertex, count
  // and the position lines before it; the parser's face callbacks to come; the kept position lines' numbers.
  struct QueuedFace {
    size_t first;
    uint32_t count;
    uint64_t positions, texcoords;
  };
  std::vector<tinyobj::index_t> faceIndices_;
  std::vector<QueuedFace> faces_;
  std::vector<FaceCall> calls_;
  std::vector<uint64_t> keptPositions_, keptTexcoords_;
  std::vector<float>* texcoords_ = nullptr;
  size_t faceHead_ = 0, callHead_ = 0, keptHead_ = 0, keptUvHead_ = 0;
};

// The OBJ file as a stream for the parser, read in 64 KiB chunks from the open file (at most `size` bytes: a
// growing file is cut there) and checked by IndexScan on the way: the file's text is never held whole. Ends the
// stream at a read error or an out-of-range index (readFailed() / badIndex() and scan() tell).
class ObjFileBuf : public std::streambuf {
 public:
  ObjFileBuf(int fd, uint64_t size, bool strict = false) : fd_(fd), left_(size), scan_(strict) {}
  ~ObjFileBuf() override { ::close(fd_); }
  ObjFileBuf(const ObjFileBuf&) = delete;
  ObjFileBuf& operator=(const ObjFileBuf&) = delete;
  bool readFailed() const { return readFailed_; }
  bool badIndex() const { return badIndex_; }
  const IndexScan& scan() const { return scan_; }
  bool nextCall(IndexScan::FaceCall& call) { return scan_.nextCall(call); }
  bool nextFace(const tinyobj::index_t*& ix, int& count, uint64_t& positions, uint64_t& texcoords) {
    return scan_.nextFace(ix, count, positions, texcoords);
  }
  void setTexcoords(std::vector<float>* uv) { scan_.setTexcoords(uv); }
  bool nextKeptTexcoord(uint64_t& index) { return scan_.nextKeptTexcoord(index); }
  bool nextKeptPosition(uint64_t& index) { return scan_.nextKeptPosition(index); }
  // Ends the stream after the bytes already handed out (the UV-only load gives up on an irregular file).
  void stop() {
    stopped_ = true;
    setg(buf_, buf_, buf_);
  }

 protected:
  int_type underflow() override {
    if (gptr() < egptr()) return traits_type::to_int_type(*gptr());
    if (readFailed_ || badIndex_ || stopped_) return traits_type::eof();
    ssize_t r = 0;
    if (left_ > 0) {
      do {
        r = ::read(fd_, buf_, size_t(std::min<uint64_t>(left_, sizeof buf_)));
      } while (r < 0 && errno == EINTR);
    }
    if (r < 0) readFailed_ = true;
    if (r <= 0) {  // the end (or the file shrank): the last line may hold an index
      if (!readFailed_ && !scan_.finish()) badIndex_ = true;
      left_ = 0;
      return traits_type::eof();
    }
    left_ -= uint64_t(r);
    size_t kept = 0;
    if (!scan_.feed(buf_, size_t(r), kept)) {
      badIndex_ = true;
      return traits_type::eof();
    }
    setg(buf_, buf_, buf_ + kept);
    return traits_type::to_int_type(buf_[0]);
  }

 private:
  int fd_;
  uint64_t left_;
  bool readFailed_ = false, badIndex_ = false, stopped_ = false;
  IndexScan scan_;
  char buf_[1 << 16];
};

// Reads mtllib files as regular files only, with the mtl size cap; a failure other than "missing" is kept and
// ends the load (tinyobjloader would only warn).
class MtlReader : public tinyobj::MaterialReader {
 public:
  MtlReader(std::filesystem::path dir, uint64_t cap) : dir_(std::move(dir)), cap_(cap) {}
  bool operator()(const std::string& matId, std::vector<tinyobj::material_t>* materials,
                  std::map<std::string, int>* matMap, std::string* warn, std::string* err) override {
    std::filesystem::path p(matId);
    if (p.is_relative()) p = dir_ / p;
    std::error_code ec;
    if (!std::filesystem::exists(std::filesystem::symlink_status(p, ec))) {
      if (warn) *warn += "material library '" + escapeName(p.string()) + "' not found\n";
      return false;
    }
    auto bytes = readRegularFile(p.string(), cap_, "material library", "file-bytes.mtl");
    if (!bytes) {
      if (error.empty()) error = "mtllib: " + bytes.error().message;
      return false;
    }
    std::istringstream in(std::string(bytes->begin(), bytes->end()));
    tinyobj::LoadMtl(matMap, materials, &in, warn, err);
    materialMap = matMap;
    read.push_back(p.string());
    if (onMaterials) onMaterials(*materials);
    return true;
  }
  std::string error;
  // Called with the materials read so far after each library (the loader starts decoding their textures while the
  // parser goes on).
  std::function<void(const std::vector<tinyobj::material_t>&)> onMaterials;
  std::vector<std::string> read;  // the material libraries read (Scene::inputFiles)
  // The parser's material name → index map (the one it passed to the last read; the UV-only load resolves usemtl
  // names in it as LoadObj does).
  const std::map<std::string, int>* materialMap = nullptr;

 private:
  std::filesystem::path dir_;
  uint64_t cap_;
};

// The alpha channel map_d's -imfchan names (the default, and an unsupported value, are handled by the caller).
AlphaChannel mapDChannel(char imfchan, bool& supported) {
  supported = true;
  switch (imfchan) {
    case 'r':
      return AlphaChannel::Red;
    case 'g':
      return AlphaChannel::Green;
    case 'b':
      return AlphaChannel::Blue;
    case 'l':
      return AlphaChannel::Luminance;
    case 'm':
      return AlphaChannel::AlphaOrLuminance;
    default:
      supported = false;
      return AlphaChannel::Luminance;
  }
}

// What the materials take from one texture file: alpha textures of some channels (AlphaOrOne: only when the image
// has an alpha channel, as map_Kd's alpha), and the colour image.
struct TextureNeeds {
  std::set<AlphaChannel> channels;
  bool color = false;
};

// One texture file converted to what the materials take from it; the decoded image itself is not kept.
struct LoadedTexture {
  bool hasAlpha = false;
  std::map<AlphaChannel, std::shared_ptr<const AlphaTexture>> alpha;
  std::shared_ptr<const ColorImage> color;
};

// Reads and decodes one texture file and converts it at once (the decoded image is freed on return).
Result<std::shared_ptr<const LoadedTexture>> loadTexture(const std::string& path, const TextureNeeds& needs) {
  Result<std::vector<uint8_t>> bytes = readImageBytes(path);
  if (!bytes.ok()) return bytes.error();
  auto t = std::make_shared<LoadedTexture>();
  if (!needs.color && needs.channels.size() == 1) {
    // Only one channel, no colour (`somm bake`): when it is the alpha of a PNG that has one, that channel alone is
    // decoded (the same texture as below; the header's checks are decodeImage's).
    const AlphaChannel ch = *needs.channels.begin();
    Result<ImageHeader> header = checkImage(bytes->data(), bytes->size());
    if (!header.ok()) return header.error();
    if (auto a = decodeAlphaFast(bytes->data(), bytes->size(), *header, ch, 1.0f, true)) {
      t->hasAlpha = true;
      t->alpha[ch] = std::make_shared<const AlphaTexture>(std::move(*a));
      return std::shared_ptr<const LoadedTexture>(std::move(t));
    }
  }
  Result<RawImage> raw = decodeImage(bytes->data(), bytes->size());
  if (!raw.ok()) return raw.error();
  std::vector<uint8_t>().swap(*bytes);  // the file's bytes are not needed any more
  const RawImage& img = raw.value();
  t->hasAlpha = img.hasAlpha();
  for (AlphaChannel ch : needs.channels)
    if (ch != AlphaChannel::AlphaOrOne || img.hasAlpha())
      t->alpha[ch] = std::make_shared<const AlphaTexture>(toAlphaTexture(img, ch, 1.0f, true));
  if (needs.color) t->color = std::make_shared<const ColorImage>(toColorImage(img, true));
  return std::shared_ptr<const LoadedTexture>(std::move(t));
}

// A vertex's UV (u, v at uv; none: 0, 0) appended to a geometry's UVs.
void appendUv(std::vector<float>& uvs, const float* uv) {
  if (uv) {
    uvs.insert(uvs.end(), {uv[0], uv[1]});
  } else {
    uvs.insert(uvs.end(), {0.0f, 0.0f});
  }
}

// Corner k (vertex li) of a polygon, fanned into triangles (v0, vk-1, vk) for k >= 2; local holds v0 and the
// previous corner.
void fanCorner(uint32_t k, uint32_t li, uint32_t local[3], std::vector<uint32_t>& indices) {
  if (k == 0) {
    local[0] = li;
  } else if (k == 1) {
    local[1] = li;
  } else {
    local[2] = li;
    indices.insert(indices.end(), {local[0], local[1], local[2]});
    local[1] = li;
  }
}

// A corner's (position, texture coordinate) key → the geometry's vertex number, first use first: open addressing
// with linear probing in one array (a node-based map allocated per insertion and took a tenth of a one-thread
// `somm bake` of TORCS forza at level 6). Keys are (v << 32 | t) with v < 2^31, so ~0 never occurs and marks a free
// slot.
class VertexMap {
 public:
  // The number stored for `key`, or `next` stored for it when it is new (inserted = true).
  std::pair<uint32_t, bool> emplace(uint64_t key, uint32_t next) {
    if (2 * (size_ + 1) > slots_.size()) grow();
    const size_t mask = slots_.size() - 1;
    for (size_t i = hash(key) & mask;; i = (i + 1) & mask) {
      Slot& s = slots_[i];
      if (s.key == key) return {s.value, false};
      if (s.key == kFree) {
        s = Slot{key, next};
        ++size_;
        return {next, true};
      }
    }
  }
  // The number stored for `key`, or null.
  const uint32_t* find(uint64_t key) const {
    if (slots_.empty()) return nullptr;
    const size_t mask = slots_.size() - 1;
    for (size_t i = hash(key) & mask;; i = (i + 1) & mask) {
      const Slot& s = slots_[i];
      if (s.key == key) return &s.value;
      if (s.key == kFree) return nullptr;
    }
  }

 private:
  static constexpr uint64_t kFree = ~uint64_t(0);
  struct Slot {
    uint64_t key = kFree;
    uint32_t value = 0;
  };
  size_t hash(uint64_t key) const { return size_t((key * 0x9E3779B97F4A7C15ull) >> 32); }
  void grow() {
    std::vector<Slot> old(std::max<size_t>(64, 2 * slots_.size()));
    old.swap(slots_);
    const size_t mask = slots_.size() - 1;
    for (const Slot& s : old) {
      if (s.key == kFree) continue;
      size_t i = hash(s.key) & mask;
      while (slots_[i].key != kFree) i = (i + 1) & mask;
      slots_[i] = s;
    }
  }
  std::vector<Slot> slots_;
  size_t size_ = 0;
};

class ObjLoader {
 public:
  ObjLoader(std::string path, const LoadOptions& opts) : path_(std::move(path)), opts_(opts) {}
  ~ObjLoader() {
    group_.cancel();  // an early return: the tasks not yet started are not needed
    try {
      group_.wait();  // (nothing left after collectImages())
    } catch (...) {  // a task's exception on a path that fails anyway (collectImages() rethrows it otherwise)
    }
  }
  ObjLoader(const ObjLoader&) = delete;
  ObjLoader& operator=(const ObjLoader&) = delete;
  Result<Scene> run();
  // The scene without positions, parsed by tinyobjloader's callback API (no whole-file arrays): the same result
  // as run() with Geometry::positions cleared, or `irregular` set when the file uses something the callback
  // parser reads differently (IndexScan's strict forms, a warning, a reference to a later or missing element):
  // then run() must load it instead. `nonFinite`: the non-finite position components of the geometries' vertices.
  Result<Scene> runUvOnly(bool& irregular, uint64_t& nonFinite);

 private:
  // After parsing: the materials (images decoded), the default material, the warning for skipped faces, one
  // instance per geometry.
  Result<Scene> finish(const std::vector<tinyobj::material_t>& mats, int defaultMaterial, size_t degenerate);
  Error fail(ErrorCode code, const std::string& what) const { return makeError(code, path_ + ": " + what); }
  Result<std::shared_ptr<const LoadedTexture>> image(const std::string& texname, const std::string& material,
                                                     std::string& resolved);
  Status material(const tinyobj::material_t& tm, Material& m);

  std::string path_;
  LoadOptions opts_;
  std::filesystem::path dir_;
  Scene scene_;
  // Converted textures, shared by every material that uses the same file: loaded once per path.
  std::map<std::string, std::shared_ptr<const LoadedTexture>> images_;
  // Every texture file the materials name, decoded and converted by tasks of group_ before the materials are read in
  // order (at most one decoded image per thread is alive at a time; only the conversions are kept); image() takes
  // its result from here (the same result a read in order would give). The tasks start as soon as a material
  // library has been read (MtlReader::onMaterials), so with two or more threads the textures are decoded while the
  // OBJ is still being parsed; with one they run when collectImages() waits for them.
  std::map<std::string, TextureNeeds> needs_;
  struct Pending {
    TextureNeeds needs;  // what the task converts (needs_ may grow after it started)
    std::optional<Result<std::shared_ptr<const LoadedTexture>>> result;
  };
  std::map<std::string, Pending> pending_;  // map nodes do not move: each task writes its own
  std::map<std::string, Result<std::shared_ptr<const LoadedTexture>>> decoded_;
  tbb::task_group group_;
  // Starts a task for every texture file the materials name that has none yet, the largest files first.
  void startImages(const std::vector<tinyobj::material_t>& mats);
  // Waits for the tasks and moves their results to decoded_ (files whose needs grew are decoded again).
  void collectImages();
  // The paths image() tries for a texture name: relative to the OBJ's folder, then with backslashes as separators.
  std::vector<std::string> candidates(const std::string& texname) const {
    std::vector<std::string> paths;
    std::filesystem::path p(texname);
    if (p.is_relative()) p = dir_ / p;
    paths.push_back(p.string());
    if (texname.find('\\') != std::string::npos) {
      std::string alt = texname;
      for (char& c : alt)
        if (c == '\\') c = '/';
      std::filesystem::path q(alt);
      if (q.is_relative()) q = dir_ / q;
      paths.push_back(q.string());
    }
    return paths;
  }
  Result<std::shared_ptr<const LoadedTexture>> readImage(const std::string& path) {
    const auto it = decoded_.find(path);
    if (it == decoded_.end()) return loadTexture(path, needs_[path]);
    return it->second;
  }
  // Channel ch of a converted texture file (prefetchImages converted every channel a material takes; should one be
  // missing, the file is decoded again for it).
  Result<std::shared_ptr<const AlphaTexture>> alphaOf(const std::string& path, const LoadedTexture& tex,
                                                      AlphaChannel ch) {
    if (auto it = tex.alpha.find(ch); it != tex.alpha.end()) return it->second;
    TextureNeeds n;
    n.channels.insert(ch);
    auto again = loadTexture(path, n);
    if (!again.ok()) return fail(again.error().code, "texture '" + path + "': " + again.error().message);
    auto it = again.value()->alpha.find(ch);
    if (it == again.value()->alpha.end())
      return fail(ErrorCode::CorruptFile, "texture '" + path + "' has no alpha");
    return it->second;
  }
};

Result<std::shared_ptr<const LoadedTexture>> ObjLoader::image(const std::string& texname,
                                                              const std::string& material,
                                                              std::string& resolved) {
  const std::vector<std::string> paths = candidates(texname);
  resolved = paths[0];
  auto it = images_.find(resolved);
  if (it != images_.end()) return it->second;
  Result<std::shared_ptr<const LoadedTexture>> raw = readImage(resolved);
  if (!raw.ok() && raw.error().code == ErrorCode::IoError && paths.size() > 1) {
    Result<std::shared_ptr<const LoadedTexture>> raw2 = readImage(paths[1]);
    if (raw2.ok()) {
      raw = std::move(raw2);
      resolved = paths[1];
    }
  }
  if (!raw.ok())
    return fail(raw.error().code,
                "material '" + material + "': texture '" + resolved + "': " + raw.error().message);
  images_[resolved] = raw.value();
  scene_.inputFiles.push_back(resolved);
  return raw.value();
}

void ObjLoader::startImages(const std::vector<tinyobj::material_t>& mats) {
  auto add = [&](const std::string& texname, bool color, std::optional<AlphaChannel> channel) {
    if (texname.empty()) return;
    for (const std::string& path : candidates(texname)) {
      TextureNeeds& n = needs_[path];
      n.color |= color;
      if (channel) n.channels.insert(*channel);
    }
  };
  for (const tinyobj::material_t& tm : mats) {
    // As material() takes them: map_Kd's colour, and its alpha when there is no map_d; map_d's channel.
    add(tm.diffuse_texname, opts_.loadColor,
        tm.alpha_texname.empty() ? std::optional<AlphaChannel>(AlphaChannel::AlphaOrOne) : std::nullopt);
    bool supported = true;
    add(tm.alpha_texname, false, mapDChannel(tm.alpha_texopt.imfchan, supported));
  }
  std::vector<std::pair<uintmax_t, std::map<std::string, Pending>::iterator>> fresh;
  for (const auto& [path, n] : needs_) {
    auto [it, added] = pending_.try_emplace(path);
    if (!added) continue;
    it->second.needs = n;
    std::error_code ec;
    const uintmax_t size = std::filesystem::file_size(path, ec);
    fresh.emplace_back(ec ? 0 : size, it);
  }
  // A thief takes the oldest task first: the largest files start first, the small ones fill in.
  std::stable_sort(fresh.begin(), fresh.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  for (const auto& f : fresh) {
    const std::string* path = &f.second->first;
    Pending* slot = &f.second->second;
    group_.run([path, slot] { slot->result.emplace(loadTexture(*path, slot->needs)); });
  }
}

void ObjLoader::collectImages() {
  group_.wait();  // rethrows a task's exception (std::bad_alloc), as the parallel loop did
  std::vector<std::pair<const std::string*, Pending*>> again;
  for (auto& [path, p] : pending_) {
    const TextureNeeds& n = needs_[path];
    const bool covered =
        p.result && (!n.color || p.needs.color) &&
        std::includes(p.needs.channels.begin(), p.needs.channels.end(), n.channels.begin(), n.channels.end());
    if (!covered) {
      p.needs = n;
      again.emplace_back(&path, &p);
    }
  }
  // Files a later material library asked more of (rare): decoded again with everything they are needed for.
  tbb::parallel_for(
      size_t(0), again.size(),
      [&](size_t i) {
        again[i].second->result.emplace(loadTexture(*again[i].first, again[i].second->needs));
      },
      tbb::simple_partitioner());
  for (auto& [path, p] : pending_) decoded_.emplace(path, std::move(*p.result));
  pending_.clear();
}

// Image formats that cannot store an alpha channel (by extension): a missing one cannot change the alpha test.
bool cannotCarryAlpha(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".jpg" || ext == ".jpeg";
}

Status ObjLoader::material(const tinyobj::material_t& tm, Material& m) {
  m.name = tm.name;
  m.doubleSided = true;  // OBJ has no culling information
  m.baseColorFactor = {float(tm.diffuse[0]), float(tm.diffuse[1]), float(tm.diffuse[2]), 1.0f};
  m.sampler.filter = Filter::Linear;
  m.alphaCutoff = 0.5f;
  auto checkOptions = [&](const tinyobj::texture_option_t& o, const char* what) {
    if (o.origin_offset[0] != 0 || o.origin_offset[1] != 0 || o.scale[0] != 1 || o.scale[1] != 1)
      scene_.warnings.push_back("material '" + m.name + "': " + what + " -o/-s options are ignored");
  };
  std::shared_ptr<const LoadedTexture> kd;
  std::string kdPath;
  if (!tm.diffuse_texname.empty()) {
    auto r = image(tm.diffuse_texname, m.name, kdPath);
    if (r.ok()) {
      kd = r.value();
      if (opts_.loadColor) m.baseColor = kd->color;
    } else if (!cannotCarryAlpha(kdPath) || std::filesystem::exists(kdPath)) {
      return r.error();
    } else {
      // A missing JPEG holds no alpha: the material is drawn opaque (untextured), as an engine would.
      scene_.warnings.push_back(
          "material '" + m.name + "': map_Kd texture '" + kdPath +
          "' is missing; a JPEG carries no alpha, so the material is drawn opaque without it");
    }
  }
  if (!tm.alpha_texname.empty()) {
    std::string dPath;
    auto r = image(tm.alpha_texname, m.name, dPath);
    if (!r.ok()) return r.error();
    bool supported = true;
    const AlphaChannel ch = mapDChannel(tm.alpha_texopt.imfchan, supported);
    if (!supported)
      scene_.warnings.push_back("material '" + m.name + "': map_d -imfchan '" +
                                std::string(1, tm.alpha_texopt.imfchan) + "' unsupported, luminance used");
    auto a = alphaOf(dPath, *r.value(), ch);
    if (!a.ok()) return a.error();
    m.alpha = a.value();
    m.alphaSource = dPath;
    const Wrap w = tm.alpha_texopt.clamp ? Wrap::ClampToEdge : Wrap::Repeat;
    m.sampler.wrapS = m.sampler.wrapT = w;
    m.alphaMode = AlphaMode::Mask;
    checkOptions(tm.alpha_texopt, "map_d");
  } else if (kd && kd->hasAlpha) {
    auto a = alphaOf(kdPath, *kd, AlphaChannel::AlphaOrOne);
    if (!a.ok()) return a.error();
    m.alpha = a.value();
    m.alphaSource = kdPath;
    const Wrap w = tm.diffuse_texopt.clamp ? Wrap::ClampToEdge : Wrap::Repeat;
    m.sampler.wrapS = m.sampler.wrapT = w;
    m.alphaMode = AlphaMode::Mask;
    checkOptions(tm.diffuse_texopt, "map_Kd");
  } else {
    m.alphaMode = AlphaMode::Opaque;
    if (kd) {
      const Wrap w = tm.diffuse_texopt.clamp ? Wrap::ClampToEdge : Wrap::Repeat;
      m.sampler.wrapS = m.sampler.wrapT = w;
    }
    if (tm.dissolve < 1.0)
      scene_.warnings.push_back("material '" + m.name +
                                "': dissolve d < 1 without an alpha texture is ignored (opaque)");
  }
  return Ok{};
}

Result<Scene> ObjLoader::run() {
  dir_ = std::filesystem::path(path_).parent_path();
  auto opened = openRegularFile(path_, opts_.limits.sceneFileBytes, "OBJ file", "file-bytes.scene");
  if (!opened) return opened.error();
  auto file = std::make_unique<ObjFileBuf>(opened->fd, opened->size);
  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> mats;
  std::string warn, err;
  MtlReader mtl(dir_, opts_.limits.mtlFileBytes);
  mtl.onMaterials = [this](const std::vector<tinyobj::material_t>& m) { startImages(m); };
  bool ok = false;
  try {
    std::istream in(file.get());
    ok = tinyobj::LoadObj(&attrib, &shapes, &mats, &warn, &err, &in, &mtl, false, false);
  } catch (const std::exception& e) {
    return fail(ErrorCode::CorruptFile, std::string("parser exception: ") + e.what());
  }
  if (file->readFailed()) return fail(ErrorCode::IoError, "read failed");
  if (file->badIndex())
    return fail(ErrorCode::CorruptFile, "line " + std::to_string(file->scan().line()) + ": index " +
                                            file->scan().token() + " is out of range (at most 2^31 - 1)");
  file.reset();
  if (!mtl.error.empty()) return fail(ErrorCode::IoError, mtl.error);
  if (!ok) {
    std::string msg = oneLine(err);
    return fail(ErrorCode::CorruptFile, msg.empty() ? "cannot parse OBJ" : msg);
  }
  splitLines(warn, scene_.warnings);
  scene_.sourcePath = path_;
  scene_.inputFiles.push_back(path_);
  scene_.inputFiles.insert(scene_.inputFiles.end(), mtl.read.begin(), mtl.read.end());
  // Geometry first, then the parser's arrays are freed, then the images are decoded: the peak holds the parsed
  // file and the geometry, or the geometry and the textures, never all three. Material indices are the file's
  // (the default material, when a face has none, comes after them); the materials are filled in below.
  int defaultMaterial = -1;
  const size_t nv = attrib.vertices.size() / 3, nt = attrib.texcoords.size() / 2;

  struct Builder {
    VertexMap remap;
  };
  std::map<std::pair<size_t, int>, uint32_t> geometryOf;
  std::vector<Builder> builders;
  size_t degenerate = 0;
  for (size_t si = 0; si < shapes.size(); ++si) {
    const tinyobj::mesh_t& mesh = shapes[si].mesh;
    const std::string shapeName = shapes[si].name.empty() ? "shape" + std::to_string(si) : shapes[si].name;
    // The shape's geometries are new ones (geometries are keyed by shape and material).
    const size_t firstOfShape = scene_.geometries.size();
    size_t offset = 0;
    for (size_t f = 0; f < mesh.num_face_vertices.size(); ++f) {
      const size_t n = mesh.num_face_vertices[f];
      if (offset + n > mesh.indices.size()) return fail(ErrorCode::CorruptFile, "inconsistent face data");
      int mat = f < mesh.material_ids.size() ? mesh.material_ids[f] : -1;
      if (mat >= int(mats.size())) mat = -1;
      if (n < 3) {
        ++degenerate;
        offset += n;
        continue;
      }
      auto key = std::make_pair(si, mat);
      auto it = geometryOf.find(key);
      if (it == geometryOf.end()) {
        Geometry g;
        if (mat < 0) {
          if (defaultMaterial < 0) defaultMaterial = int(mats.size());
          g.material = uint32_t(defaultMaterial);
        } else {
          g.material = uint32_t(mat);
        }
        g.name = shapeName + "/" + (mat < 0 ? std::string("default") : mats[size_t(mat)].name);
        it = geometryOf.emplace(key, uint32_t(scene_.geometries.size())).first;
        scene_.geometries.push_back(std::move(g));
        builders.emplace_back();
      }
      Geometry& g = scene_.geometries[it->second];
      Builder& b = builders[it->second];
      uint32_t local[3] = {0, 0, 0};
      for (size_t k = 0; k < n; ++k) {
        const tinyobj::index_t& ix = mesh.indices[offset + k];
        if (ix.vertex_index < 0 || size_t(ix.vertex_index) >= nv)
          return fail(ErrorCode::CorruptFile, "face " + std::to_string(f + 1) + " of shape '" + shapeName +
                                                  "' refers to vertex " +
                                                  std::to_string(ix.vertex_index + 1) + " but the file has " +
                                                  std::to_string(nv) + " vertices");
        if (ix.texcoord_index >= 0 && size_t(ix.texcoord_index) >= nt)
          return fail(ErrorCode::CorruptFile,
                      "face " + std::to_string(f + 1) + " of shape '" + shapeName +
                          "' refers to texture coordinate " + std::to_string(ix.texcoord_index + 1) +
                          " but the file has " + std::to_string(nt) + " texture coordinates");
        const uint64_t vkey = (uint64_t(uint32_t(ix.vertex_index)) << 32) | uint32_t(ix.texcoord_index);
        const auto [vertex, inserted] = b.remap.emplace(vkey, uint32_t(g.positions.size() / 3));
        if (inserted) {
          const size_t v = size_t(ix.vertex_index);
          g.positions.insert(g.positions.end(), {attrib.vertices[3 * v], attrib.vertices[3 * v + 1],
                                                 attrib.vertices[3 * v + 2]});
          appendUv(g.uvs,
                   ix.texcoord_index >= 0 ? &attrib.texcoords[2 * size_t(ix.texcoord_index)] : nullptr);
        }
        fanCorner(uint32_t(k), vertex, local, g.indices);
      }
      offset += n;
    }
    // The shape is done: its faces, its geometries' vertex maps and their growth slack are freed now rather than
    // at the end, so that the parser's arrays and ours do not peak together.
    shapes[si].mesh = tinyobj::mesh_t{};
    for (size_t gi = firstOfShape; gi < scene_.geometries.size(); ++gi) {
      builders[gi] = Builder{};
      Geometry& g = scene_.geometries[gi];
      g.positions.shrink_to_fit();
      g.uvs.shrink_to_fit();
      g.indices.shrink_to_fit();
    }
  }
  attrib = tinyobj::attrib_t{};
  std::vector<tinyobj::shape_t>().swap(shapes);
  std::vector<Builder>().swap(builders);
  return finish(mats, defaultMaterial, degenerate);
}

Result<Scene> ObjLoader::finish(const std::vector<tinyobj::material_t>& mats, int defaultMaterial,
                                size_t degenerate) {
  startImages(mats);  // the textures of materials no library read announced (none when the hook saw them all)
  collectImages();
  for (const auto& tm : mats) {
    Material m;
    Status st = material(tm, m);
    if (!st.ok()) return st.error();
    scene_.materials.push_back(std::move(m));
  }
  images_.clear();
  decoded_.clear();
  if (defaultMaterial >= 0) {
    Material d;
    d.name = "default";
    scene_.materials.push_back(d);
  }
  if (degenerate)
    scene_.warnings.push_back(std::to_string(degenerate) + " face(s) with fewer than 3 vertices skipped");
  for (uint32_t g = 0; g < scene_.geometries.size(); ++g) {
    Instance inst;  // identity transform (OBJ has no nodes)
    inst.geometry = g;
    scene_.instances.push_back(inst);
  }
  (void)opts_;
  return std::move(scene_);
}

// The UV-only parse: tinyobjloader's callback parser calls these with each element; shapes are split as LoadObj
// splits them (a new shape at g and o once the current one has faces; usemtl does not split), so the geometries
// (keyed by shape and material), their vertex numbering (by (v, vt) pair in order of first use) and triangles
// are those of run().
struct UvParse {
  Scene* scene = nullptr;
  ObjFileBuf* file = nullptr;
  const MtlReader* mtl = nullptr;
  std::vector<tinyobj::material_t> mats;
  std::vector<float> vt;  // u, v per texture coordinate
  // The positions with x, y or z not finite: (number, how many of the three), in file order.
  std::vector<std::pair<uint64_t, uint8_t>> badPositions;
  uint64_t lastPositions = 0;  // position lines before the last face
  uint64_t normals = 0;
  int material = -1;
  std::string name;   // the name of the current shape (g or o)
  size_t shapes = 0;  // shapes LoadObj has pushed before the current one
  bool shapeHasFaces = false;
  bool irregular = false;
  uint64_t nonFinite = 0;
  // Geometry::material of the geometries with the default material until the file's materials are all known.
  static constexpr uint32_t kDefault = ~0u;
  // The current shape's geometries by material: the geometry and the (v, vt) → vertex pairs of it that are not in
  // pairSlots (`spilled`: it holds any).
  struct Open {
    uint32_t geometry = 0;
    bool spilled = false;
    VertexMap remap;
  };
  std::map<int, Open> geometryOf;
  // The (v, vt) → vertex numbering of the open geometries (the current shape's, numbered from shapeFirst on): per
  // position the last pair that used it (its geometry, texture coordinate and vertex), the other pairs in their
  // geometry's `remap` (a pair leaves the slot for its geometry's map when another one takes the slot). Most
  // positions are used by one geometry with one texture coordinate: most lookups read one slot of a dense array,
  // in the file's order, instead of probing a hash table (whose memory, faulted in as it grows, and scattered
  // reads cost more than the parse on TORCS forza).
  struct PairSlot {
    uint32_t geometry = UINT32_MAX;
    uint32_t vt = 0;
    uint32_t vertex = 0;
  };
  // By position − slotBase (the positions read before the shape began; the pairs of earlier positions, which a shape
  // seldom uses, go to their geometry's map).
  std::vector<PairSlot> pairSlots;
  uint32_t slotBase = 0;
  uint32_t shapeFirst = 0;
  std::vector<Open*> openGeometries;  // by geometry − shapeFirst

  // The vertex of pair (v, t) in the open geometry `o`, or `next` when the pair is new (inserted = true).
  std::pair<uint32_t, bool> number(Open& o, uint32_t v, uint32_t t, uint32_t next) {
    const uint64_t key = (uint64_t(v) << 32) | t;
    if (v < slotBase) {
      o.spilled = true;
      return o.remap.emplace(key, next);
    }
    const size_t i = v - slotBase;
    if (i >= pairSlots.size()) pairSlots.resize(std::max(i + 1, 2 * pairSlots.size()));
    PairSlot& s = pairSlots[i];
    if (s.geometry == o.geometry && s.vt == t) return {s.vertex, false};
    if (o.spilled)
      if (const uint32_t* found = o.remap.find(key)) return {*found, false};
    if (s.geometry != UINT32_MAX && s.geometry >= shapeFirst) {  // an open geometry's pair: to its map
      Open& owner = *openGeometries[s.geometry - shapeFirst];
      owner.remap.emplace((uint64_t(v) << 32) | s.vt, s.vertex);
      owner.spilled = true;
    }
    s = PairSlot{o.geometry, t, next};
    return {next, true};
  }

  void giveUp() {
    irregular = true;
    file->stop();
  }
  // LoadObj pushes the current shape (when it has faces) and starts a new one.
  void endShape() {
    if (shapeHasFaces) {
      ++shapes;
      for (const auto& [mat, open] : geometryOf) {
        Geometry& g = scene->geometries[open.geometry];
        g.uvs.shrink_to_fit();
        g.indices.shrink_to_fit();
      }
    }
    shapeHasFaces = false;
    geometryOf.clear();
    openGeometries.clear();
    shapeFirst = uint32_t(scene->geometries.size());
    pairSlots.clear();
    slotBase =
        uint32_t(std::min<uint64_t>(lastPositions, UINT32_MAX));  // at most the positions before the shape
  }
  // A raw index (non-zero: IndexScan's strict forms) resolved as LoadObj's fixIndex does against the `count`
  // elements read so far; -1 when it does not name one of them (LoadObj would warn or the loader fail).
  static int64_t resolve(int raw, uint64_t count) {
    const int64_t i = raw > 0 ? int64_t(raw) - 1 : int64_t(count) + int64_t(raw);
    return i >= 0 && uint64_t(i) < count ? i : -1;
  }
  // A face callback of the parser: an f line it read, or "f 0", a run of faces the scan read (IndexScan::nextCall).
  void face(const tinyobj::index_t* ix, int n) {
    if (irregular) return;
    const bool marker =
        n == 1 && ix[0].vertex_index == 0 && ix[0].texcoord_index == 0 && ix[0].normal_index == 0;
    IndexScan::FaceCall call;
    if (!file->nextCall(call) || (call.faces != 0) != marker) return giveUp();
    if (!marker) return addFace(ix, n, call.positions, call.texcoords);
    for (uint32_t k = 0; k < call.faces && !irregular; ++k) {
      uint64_t positions = 0, texcoords = 0;
      if (!file->nextFace(ix, n, positions, texcoords)) return giveUp();
      addFace(ix, n, positions, texcoords);
    }
  }
  // How many of x, y, z of position v are not finite.
  uint8_t badCount(uint64_t v) const {
    const auto it = std::lower_bound(badPositions.begin(), badPositions.end(), std::make_pair(v, uint8_t(0)));
    return it != badPositions.end() && it->first == v ? it->second : 0;
  }
  // A face of n raw indices after `nv` position and `nt` texture coordinate lines.
  void addFace(const tinyobj::index_t* ix, int n, uint64_t nv, uint64_t nt) {
    if (n < 3) return giveUp();  // LoadObj warns ("Degenerated face") and skips it
    lastPositions = nv;
    int mat = material;
    if (mat >= int(mats.size())) mat = -1;
    auto [it, added] = geometryOf.try_emplace(mat);
    if (added) {
      Geometry g;
      g.material = mat < 0 ? kDefault : uint32_t(mat);
      const std::string shapeName = name.empty() ? "shape" + std::to_string(shapes) : name;
      g.name = shapeName + "/" + (mat < 0 ? std::string("default") : mats[size_t(mat)].name);
      it->second.geometry = uint32_t(scene->geometries.size());
      scene->geometries.push_back(std::move(g));
      openGeometries.push_back(&it->second);
    }
    Geometry& g = scene->geometries[it->second.geometry];
    uint32_t local[3] = {0, 0, 0};
    for (int k = 0; k < n; ++k) {
      const int64_t v = resolve(ix[k].vertex_index, nv);
      const int64_t t = ix[k].texcoord_index == 0 ? -1 : resolve(ix[k].texcoord_index, nt);
      if (v < 0 || (ix[k].texcoord_index != 0 && t < 0) ||
          (ix[k].normal_index != 0 && resolve(ix[k].normal_index, normals) < 0))
        return giveUp();
      const auto [vertex, inserted] =
          number(it->second, uint32_t(v), uint32_t(int32_t(t)), uint32_t(g.uvs.size() / 2));
      if (inserted) {
        if (!badPositions.empty()) nonFinite += badCount(uint64_t(v));
        appendUv(g.uvs, t >= 0 ? &vt[2 * size_t(t)] : nullptr);
      }
      fanCorner(uint32_t(k), vertex, local, g.indices);
    }
    shapeHasFaces = true;
  }
};

Result<Scene> ObjLoader::runUvOnly(bool& irregular, uint64_t& nonFinite) {
  irregular = false;
  dir_ = std::filesystem::path(path_).parent_path();
  auto opened = openRegularFile(path_, opts_.limits.sceneFileBytes, "OBJ file", "file-bytes.scene");
  if (!opened) return opened.error();
  auto file = std::make_unique<ObjFileBuf>(opened->fd, opened->size, true);
  std::string warn, err;
  MtlReader mtl(dir_, opts_.limits.mtlFileBytes);
  mtl.onMaterials = [this](const std::vector<tinyobj::material_t>& m) { startImages(m); };
  UvParse u;
  u.scene = &scene_;
  u.file = file.get();
  u.mtl = &mtl;
  file->setTexcoords(&u.vt);
  tinyobj::callback_t cb;
  cb.vertex_cb = [](void* d, tinyobj::real_t x, tinyobj::real_t y, tinyobj::real_t z, tinyobj::real_t) {
    UvParse& u = *static_cast<UvParse*>(d);
    uint64_t index = 0;
    if (!u.file->nextKeptPosition(index)) return u.giveUp();
    const auto bad = uint8_t(!std::isfinite(x) + !std::isfinite(y) + !std::isfinite(z));
    if (bad != 0) u.badPositions.emplace_back(index, bad);
  };
  cb.normal_cb = [](void* d, tinyobj::real_t, tinyobj::real_t, tinyobj::real_t) {
    ++static_cast<UvParse*>(d)->normals;
  };
  cb.texcoord_cb = [](void* d, tinyobj::real_t x, tinyobj::real_t y, tinyobj::real_t) {
    UvParse& u = *static_cast<UvParse*>(d);
    uint64_t index = 0;
    if (!u.file->nextKeptTexcoord(index)) return u.giveUp();
    u.vt[2 * index] = float(x);
    u.vt[2 * index + 1] = float(y);
  };
  cb.index_cb = [](void* d, tinyobj::index_t* ix, int n) { static_cast<UvParse*>(d)->face(ix, n); };
  cb.usemtl_cb = [](void* d, const char* text, int) {
    UvParse& u = *static_cast<UvParse*>(d);
    // LoadObj's name: the first word after "usemtl" (the callback parser passes the rest of the line).
    const char* p = text + std::strspn(text, " \t");
    const std::string nm(p, std::strcspn(p, " \t\r"));
    const std::map<std::string, int>* map = u.mtl->materialMap;
    const auto it = map ? map->find(nm) : std::map<std::string, int>::const_iterator{};
    if (!map || it == map->end()) return u.giveUp();  // LoadObj warns (material not found)
    u.material = it->second;
  };
  cb.mtllib_cb = [](void* d, const tinyobj::material_t* m, int n) {
    auto& mats = static_cast<UvParse*>(d)->mats;
    mats.assign(m, m + n);
  };
  cb.group_cb = [](void* d, const char** names, int n) {
    UvParse& u = *static_cast<UvParse*>(d);
    if (n < 1) return u.giveUp();  // LoadObj warns (empty group name)
    u.endShape();
    u.name = names[0];
    for (int i = 1; i < n; ++i) u.name += std::string(" ") + names[i];
  };
  cb.object_cb = [](void* d, const char* name) {
    UvParse& u = *static_cast<UvParse*>(d);
    u.endShape();
    u.name = name;
  };
  try {
    std::istream in(file.get());
    tinyobj::LoadObjWithCallback(in, cb, &u, &mtl, &warn, &err);
  } catch (const std::exception& e) {
    return fail(ErrorCode::CorruptFile, std::string("parser exception: ") + e.what());
  }
  if (u.irregular || file->scan().irregular() || file->readFailed() || file->badIndex() ||
      !mtl.error.empty() || !warn.empty() || !err.empty()) {
    irregular = true;  // run() loads it and reports what LoadObj and the checks report
    return fail(ErrorCode::CorruptFile, "irregular");
  }
  u.endShape();
  file.reset();
  scene_.sourcePath = path_;
  scene_.inputFiles.push_back(path_);
  scene_.inputFiles.insert(scene_.inputFiles.end(), mtl.read.begin(), mtl.read.end());
  std::vector<float>().swap(u.vt);
  std::vector<std::pair<uint64_t, uint8_t>>().swap(u.badPositions);
  // The default material, when used, comes after the file's (as in run()).
  int defaultMaterial = -1;
  for (Geometry& g : scene_.geometries)
    if (g.material == UvParse::kDefault) g.material = uint32_t(defaultMaterial = int(u.mats.size()));
  nonFinite = u.nonFinite;
  return finish(u.mats, defaultMaterial, 0);
}

}  // namespace

Result<Scene> loadObjUvOnly(const std::string& path, const LoadOptions& options, bool& irregular,
                            uint64_t& nonFinitePositions) {
  nonFinitePositions = 0;
  ObjLoader uv(path, options);
  return uv.runUvOnly(irregular, nonFinitePositions);
}

Result<Scene> loadObj(const std::string& path, const LoadOptions& options, uint64_t& nonFinitePositions) {
  nonFinitePositions = 0;
  if (!options.loadPositions) {
    bool irregular = false;
    Result<Scene> r = loadObjUvOnly(path, options, irregular, nonFinitePositions);
    if (!irregular) return r;
    nonFinitePositions = 0;
  }
  ObjLoader loader(path, options);
  return loader.run();  // with positions; loadScene counts and drops them when they are not wanted
}

}  // namespace somm::detail
