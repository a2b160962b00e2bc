// drtv/netsource/http_source.h — the streamer's sector source over HTTP(S) range requests.
//
// The archive file is served as it is, byte for byte (formats/archive.h): by any static web
// server, CDN or object store (an S3 or GCS presigned URL) that answers `Range: bytes=a-b` with
// 206 Partial Content. open() reads the 64-byte header and the manifest once, with the checks
// ArchiveReader::open runs on a file (decodeArchiveHeader, decodeArchiveManifest); then each
// read() is one range request for one sector's compressed payload, which the streamer checks
// (size, XXH3, zstd, decode, key) exactly as it checks a file's.
//
// A separate library (drtv::netsource, libcurl private) so that an engine that reads files links
// no network library: drtv::streamer knows only the SectorSource interface.
//
// Connections. A pool of libcurl easy handles, each keeping its connection alive between reads
// (HTTP/1.1 keep-alive; TLS sessions are resumed). read() takes a free handle, so as many reads
// run at once as threads call it, up to max_connections; run the streamer with io_threads between
// 8 and 32 (and max_in_flight at least that) to keep that many requests in flight over a network
// with latency.
//
// Faults. Each attempt has a connect timeout and a whole-request timeout. An attempt that fails
// with a connection error (refused, reset, DNS), a timeout, a body shorter than asked for, or a
// 5xx answer is retried after a back-off that doubles from retry_initial_ms up to retry_max_ms,
// at most max_attempts attempts in all; 404 (gone), 416 (range outside the file), other 4xx, and
// a 200 answer are final. A 200 means the server ignored the Range header and is sending the whole
// archive: the transfer is aborted on its first body bytes, never read to the end. A 206 whose
// Content-Range names other bytes, or a file of another size than the header's (the archive was
// replaced on the server), is final too. Every error names the URL, the sector and the byte range.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "drtv/formats/archive.h"
#include "drtv/formats/error.h"
#include "drtv/streamer/sector_source.h"

namespace drtv::netsource {

struct HttpOptions {
  int max_connections = 16;         // easy handles (kept-alive connections), reads at once; >= 1
  long connect_timeout_ms = 2000;   // per attempt: TCP (+ TLS) connect, milliseconds
  long request_timeout_ms = 5000;   // per attempt: the whole request, connect included, milliseconds
  int max_attempts = 4;             // attempts per read, first included; >= 1
  long retry_initial_ms = 50;       // back-off before the second attempt, milliseconds
  long retry_max_ms = 1000;         // the back-off doubles up to this
  bool verify_tls = true;           // check the server's certificate and host name (https)
};

// Counts since open(), for reports and tests. Read with stats(); updated atomically.
struct HttpStats {
  uint64_t requests = 0;     // attempts made (range requests sent), open()'s included
  uint64_t connections = 0;  // new connections opened for them (the rest reused a kept-alive one)
  uint64_t retries = 0;      // attempts after a retryable failure
  uint64_t failures = 0;     // reads that returned an Error (after their last attempt)
  uint64_t bytes = 0;        // payload bytes received in successful reads
  uint64_t refused_200 = 0;  // answers that ignored Range (200), aborted
};

// True if `path_or_url` starts with http:// or https:// (case-insensitive): what the tools use to
// choose between a file and this source.
bool isHttpUrl(std::string_view path_or_url);

class HttpSectorSource final : public streamer::SectorSource {
 public:
  // Reads and checks `url`'s header and manifest (two range requests, retried as reads are).
  // Errors: the URL and what failed (connection, status, a header or manifest check).
  // Preconditions (bugs): options.max_connections >= 1, options.max_attempts >= 1. libcurl
  // honours the http_proxy / https_proxy / no_proxy environment variables.
  static Result<std::unique_ptr<HttpSectorSource>> open(const std::string& url, HttpOptions options = {});
  ~HttpSectorSource() override;
  HttpSectorSource(const HttpSectorSource&) = delete;
  HttpSectorSource& operator=(const HttpSectorSource&) = delete;

  // The manifest open() read and checked.
  const Manifest& manifest() const { return manifest_; }
  // entry.compressed_bytes bytes at entry.offset, by one range request (retried as above).
  // Error: "<url>: sector (x,y): bytes a-b: <what>". Thread-safe: up to max_connections calls run
  // at once, more wait for a free connection.
  Result<std::vector<uint8_t>> read(const SectorEntry& entry) override;
  // The URL, for messages.
  const std::string& name() const override { return url_; }
  // Counts since open(). Thread-safe (each count is read atomically, not all at one instant).
  HttpStats stats() const;

 private:
  struct Handle;
  HttpSectorSource(std::string url, HttpOptions options);
  // `bytes` bytes at `offset`; `what` names them in errors ("sector (3,-1)", "the header").
  // expected_total: the file size every answer's Content-Range must state (0: any, reported in
  // *total).
  Result<std::vector<uint8_t>> readRange(uint64_t offset, uint64_t bytes, const std::string& what, uint64_t expected_total,
                                         uint64_t* total);
  Handle* acquire();
  void release(Handle* handle);

  std::string url_;
  HttpOptions options_;
  Manifest manifest_;
  uint64_t file_bytes_ = 0;

  std::mutex mutex_;
  std::condition_variable freed_;
  std::vector<std::unique_ptr<Handle>> handles_;  // all made so far (<= max_connections)
  std::vector<Handle*> free_;

  std::atomic<uint64_t> requests_{0}, connections_{0}, retries_{0}, failures_{0}, bytes_{0}, refused_200_{0};
};

}  // namespace drtv::netsource
