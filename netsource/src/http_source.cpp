// The HTTP(S) sector source (http_source.h): range requests through a pool of libcurl easy
// handles. libcurl's errors are translated here, at the adapter, into drtv::Error messages that
// name the URL, the sector and the byte range.
#include "drtv/netsource/http_source.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <chrono>
#include <cstring>
#include <mutex>
#include <thread>

#include <curl/curl.h>

namespace drtv::netsource {
namespace {

// What one attempt saw, filled by libcurl's callbacks on the calling thread.
struct Attempt {
  CURL* easy = nullptr;
  std::vector<uint8_t>* body = nullptr;
  uint64_t want = 0;             // bytes asked for
  std::string content_range;     // of the last response's headers ("bytes a-b/total")
  long refused_status = 0;       // not 206: the status on which the body was refused
  bool too_long = false;         // more body than asked for: aborted
};

size_t onHeader(char* data, size_t size, size_t n, void* user) {
  auto& a = *static_cast<Attempt*>(user);
  const std::string_view line(data, size * n);
  // A new status line starts a new response (after a redirect or a 100 Continue): forget the last.
  if (line.starts_with("HTTP/")) a.content_range.clear();
  constexpr std::string_view kName = "content-range:";
  if (line.size() > kName.size() &&
      std::equal(kName.begin(), kName.end(), line.begin(), [](char x, char y) { return x == std::tolower((unsigned char)y); })) {
    std::string_view v = line.substr(kName.size());
    while (!v.empty() && (v.front() == ' ' || v.front() == '\t')) v.remove_prefix(1);
    while (!v.empty() && (v.back() == '\r' || v.back() == '\n' || v.back() == ' ')) v.remove_suffix(1);
    a.content_range.assign(v);
  }
  return size * n;
}

size_t onBody(char* data, size_t size, size_t n, void* user) {
  auto& a = *static_cast<Attempt*>(user);
  long status = 0;
  curl_easy_getinfo(a.easy, CURLINFO_RESPONSE_CODE, &status);
  // Anything but 206 is refused on its first body bytes: a 200 is the whole archive (the server
  // ignored Range), an error page is not a payload. Returning a short count aborts the transfer.
  if (status != 206) {
    a.refused_status = status;
    return 0;
  }
  const size_t bytes = size * n;
  if (a.body->size() + bytes > a.want) {
    a.too_long = true;
    return 0;
  }
  a.body->insert(a.body->end(), reinterpret_cast<const uint8_t*>(data), reinterpret_cast<const uint8_t*>(data) + bytes);
  return bytes;
}

// "bytes a-b/total" (total may be "*": 0). False if malformed.
bool parseContentRange(std::string_view v, uint64_t& first, uint64_t& last, uint64_t& total) {
  constexpr std::string_view kUnit = "bytes ";
  if (!v.starts_with(kUnit)) return false;
  v.remove_prefix(kUnit.size());
  const char* p = v.data();
  const char* end = v.data() + v.size();
  auto r = std::from_chars(p, end, first);
  if (r.ec != std::errc() || r.ptr == end || *r.ptr != '-') return false;
  r = std::from_chars(r.ptr + 1, end, last);
  if (r.ec != std::errc() || r.ptr == end || *r.ptr != '/' || last < first) return false;
  if (std::string_view(r.ptr + 1, end) == "*") {
    total = 0;
    return true;
  }
  r = std::from_chars(r.ptr + 1, end, total);
  return r.ec == std::errc() && r.ptr == end && last < total;
}

// libcurl results worth another attempt: the connection or the server may come back.
bool retryable(CURLcode rc) {
  switch (rc) {
    case CURLE_COULDNT_RESOLVE_HOST:
    case CURLE_COULDNT_RESOLVE_PROXY:
    case CURLE_COULDNT_CONNECT:
    case CURLE_OPERATION_TIMEDOUT:
    case CURLE_PARTIAL_FILE:
    case CURLE_RECV_ERROR:
    case CURLE_SEND_ERROR:
    case CURLE_GOT_NOTHING:
    case CURLE_WEIRD_SERVER_REPLY:
    case CURLE_HTTP2:
    case CURLE_HTTP2_STREAM:
    case CURLE_SSL_CONNECT_ERROR:
      return true;
    default:
      return false;
  }
}

std::once_flag curl_init;

}  // namespace

bool isHttpUrl(std::string_view s) {
  auto starts = [&](std::string_view prefix) {
    return s.size() >= prefix.size() &&
           std::equal(prefix.begin(), prefix.end(), s.begin(), [](char x, char y) { return x == std::tolower((unsigned char)y); });
  };
  return starts("http://") || starts("https://");
}

struct HttpSectorSource::Handle {
  CURL* easy = nullptr;
  char error[CURL_ERROR_SIZE] = {};
  ~Handle() {
    if (easy) curl_easy_cleanup(easy);
  }
};

HttpSectorSource::HttpSectorSource(std::string url, HttpOptions options) : url_(std::move(url)), options_(options) {}
HttpSectorSource::~HttpSectorSource() = default;

HttpStats HttpSectorSource::stats() const {
  return {requests_.load(), connections_.load(), retries_.load(), failures_.load(), bytes_.load(), refused_200_.load()};
}

Result<std::unique_ptr<HttpSectorSource>> HttpSectorSource::open(const std::string& url, HttpOptions options) {
  DRTV_CHECK_LE(1, options.max_connections);
  DRTV_CHECK_LE(1, options.max_attempts);
  if (!isHttpUrl(url)) return fail(url + ": not an http:// or https:// URL");
  // curl_global_init is not thread-safe: once per process, before the first handle.
  std::call_once(curl_init, [] { curl_global_init(CURL_GLOBAL_DEFAULT); });
  std::unique_ptr<HttpSectorSource> s(new HttpSectorSource(url, options));
  uint64_t total = 0;
  auto head = s->readRange(0, kArchiveHeaderBytes, "the header", 0, &total);
  if (!head) return std::unexpected(head.error());
  auto header = decodeArchiveHeader(*head, total, url);
  if (!header) return std::unexpected(header.error());
  s->file_bytes_ = total;
  // decodeArchiveHeader bounded the manifest by the file size the server states; the body is
  // appended as it arrives, never allocated from that figure alone.
  auto manifest = s->readRange(header->manifest_offset, header->manifest_bytes, "the manifest", total, nullptr);
  if (!manifest) return std::unexpected(manifest.error());
  auto parsed = decodeArchiveManifest(*header, *manifest, url);
  if (!parsed) return std::unexpected(parsed.error());
  s->manifest_ = std::move(*parsed);
  // open()'s reads are not a sector's: count only the reads the streamer makes as bytes.
  s->bytes_ = 0;
  return s;
}

Result<std::vector<uint8_t>> HttpSectorSource::read(const SectorEntry& entry) {
  auto bytes = readRange(entry.offset, entry.compressed_bytes, "sector " + toString(entry.key), file_bytes_, nullptr);
  if (bytes) bytes_ += bytes->size();
  return bytes;
}

HttpSectorSource::Handle* HttpSectorSource::acquire() {
  std::unique_lock lock(mutex_);
  freed_.wait(lock, [&] { return !free_.empty() || handles_.size() < size_t(options_.max_connections); });
  if (!free_.empty()) {
    Handle* h = free_.back();
    free_.pop_back();
    return h;
  }
  auto h = std::make_unique<Handle>();
  h->easy = curl_easy_init();
  DRTV_CHECK(h->easy != nullptr);  // out of memory
  handles_.push_back(std::move(h));
  return handles_.back().get();
}

void HttpSectorSource::release(Handle* h) {
  {
    std::lock_guard lock(mutex_);
    free_.push_back(h);
  }
  freed_.notify_one();
}

Result<std::vector<uint8_t>> HttpSectorSource::readRange(uint64_t offset, uint64_t want, const std::string& what,
                                                         uint64_t expected_total, uint64_t* total_out) {
  const uint64_t last = offset + want - 1;
  const std::string where = url_ + ": " + what + ": bytes " + std::to_string(offset) + "-" + std::to_string(last);
  if (want == 0) return std::vector<uint8_t>{};
  // The header is read before the file size is known: a file shorter than 64 bytes answers with
  // fewer, and decodeArchiveHeader says it is truncated.
  const bool short_to_end_ok = expected_total == 0;
  const std::string range = std::to_string(offset) + "-" + std::to_string(last);
  Handle* h = acquire();
  struct Release {
    HttpSectorSource* s;
    Handle* h;
    ~Release() { s->release(h); }
  } releaser{this, h};

  std::string last_error;
  long backoff_ms = options_.retry_initial_ms;
  for (int attempt = 1; attempt <= options_.max_attempts; ++attempt) {
    if (attempt > 1) {
      ++retries_;
      std::this_thread::sleep_for(std::chrono::milliseconds(backoff_ms));
      backoff_ms = std::min(options_.retry_max_ms, backoff_ms * 2);
    }
    ++requests_;
    std::vector<uint8_t> body;
    body.reserve(size_t(std::min<uint64_t>(want, 1 << 20)));
    Attempt a;
    a.easy = h->easy;
    a.body = &body;
    a.want = want;
    CURL* c = h->easy;
    curl_easy_reset(c);  // keeps the connection cache: the connection stays alive
    h->error[0] = 0;
    curl_easy_setopt(c, CURLOPT_URL, url_.c_str());
    curl_easy_setopt(c, CURLOPT_RANGE, range.c_str());
    curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);  // no SIGALRM for timeouts: we run on many threads
    curl_easy_setopt(c, CURLOPT_CONNECTTIMEOUT_MS, options_.connect_timeout_ms);
    curl_easy_setopt(c, CURLOPT_TIMEOUT_MS, options_.request_timeout_ms);
    curl_easy_setopt(c, CURLOPT_FOLLOWLOCATION, 1L);
    curl_easy_setopt(c, CURLOPT_MAXREDIRS, 5L);
    curl_easy_setopt(c, CURLOPT_TCP_KEEPALIVE, 1L);
    curl_easy_setopt(c, CURLOPT_SSL_VERIFYPEER, options_.verify_tls ? 1L : 0L);
    curl_easy_setopt(c, CURLOPT_SSL_VERIFYHOST, options_.verify_tls ? 2L : 0L);
    curl_easy_setopt(c, CURLOPT_USERAGENT, "drtv-netsource/1");
    curl_easy_setopt(c, CURLOPT_ERRORBUFFER, h->error);
    curl_easy_setopt(c, CURLOPT_HEADERFUNCTION, onHeader);
    curl_easy_setopt(c, CURLOPT_HEADERDATA, &a);
    curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, onBody);
    curl_easy_setopt(c, CURLOPT_WRITEDATA, &a);
    const CURLcode rc = curl_easy_perform(c);
    long status = 0, connects = 0;
    curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, &status);
    curl_easy_getinfo(c, CURLINFO_NUM_CONNECTS, &connects);
    connections_ += uint64_t(connects);

    if (a.too_long) {
      ++failures_;
      return fail(where + ": the server sent more than the " + std::to_string(want) + " bytes asked for");
    }
    const bool answered = rc == CURLE_OK || (rc == CURLE_WRITE_ERROR && a.refused_status != 0);
    if (!answered) {
      last_error = std::string(curl_easy_strerror(rc)) + (h->error[0] ? std::string(": ") + h->error : std::string());
      if (retryable(rc)) continue;
      ++failures_;
      return fail(where + ": " + last_error);
    }
    if (status == 200) {
      ++refused_200_;
      ++failures_;
      return fail(where + ": the server ignored the Range header (200 OK, the whole file), transfer aborted: serve the archive "
                          "from a server that answers range requests with 206");
    }
    if (status >= 500 && status <= 599) {
      last_error = "HTTP " + std::to_string(status);
      continue;
    }
    if (status != 206) {
      ++failures_;
      return fail(where + ": HTTP " + std::to_string(status) +
                  (status == 404 ? " (not found)" : status == 416 ? " (range not satisfiable: the file is shorter)" : ""));
    }
    uint64_t first = 0, end = 0, total = 0;
    if (!parseContentRange(a.content_range, first, end, total)) {
      ++failures_;
      return fail(where + ": 206 with Content-Range '" + a.content_range + "', expected 'bytes " + range + "/<size>'");
    }
    if (expected_total != 0 && total != 0 && total != expected_total) {
      ++failures_;
      return fail(where + ": the file on the server has " + std::to_string(total) + " bytes, the archive opened had " +
                  std::to_string(expected_total) + ": it was replaced; open it again");
    }
    if (short_to_end_ok && total == 0) {
      ++failures_;
      return fail(where + ": 206 with Content-Range '" + a.content_range + "' gives no file size");
    }
    const bool whole = end == last || (short_to_end_ok && end + 1 == total && end < last);
    if (first != offset || !whole) {
      ++failures_;
      return fail(where + ": 206 with Content-Range '" + a.content_range + "', other bytes than asked for");
    }
    if (body.size() != end - first + 1) {  // cut short without libcurl noticing (no length known)
      last_error = "short body: " + std::to_string(body.size()) + " of " + std::to_string(end - first + 1) + " bytes";
      continue;
    }
    if (total_out) *total_out = total;
    return body;
  }
  ++failures_;
  return fail(where + ": " + last_error + " (gave up after " + std::to_string(options_.max_attempts) + " attempts)");
}

}  // namespace drtv::netsource
