// An archive named by a file path or an http(s):// URL, as `drtv info`, `query` and `fly` take it:
// its checked manifest and the sector source to read its payloads through (FileSectorSource, or
// netsource's HttpSectorSource when this build has drtv::netsource).
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "drtv/formats/archive.h"
#include "drtv/formats/error.h"
#include "drtv/streamer/sector_source.h"

namespace drtv::app {

struct OpenedArchive {
  Manifest manifest;                                // checked as ArchiveReader::open checks it
  std::shared_ptr<streamer::SectorSource> source;   // reads payloads as stored, unchecked
  bool http = false;                                // read over HTTP
  // HTTP only: "N requests on C connections, R retries, F failed reads, B payload bytes" since
  // open; empty for a file.
  std::function<std::string()> http_stats;
};

// True for an http:// or https:// URL (case-insensitive).
bool isArchiveUrl(const std::string& path_or_url);
// Opens `path_or_url`. `http_connections`: connections (reads in flight) for a URL. Error: the
// path or URL and what failed; a URL in a build without drtv::netsource says so.
Result<OpenedArchive> openArchive(const std::string& path_or_url, int http_connections = 16);
// One sector read through `a.source`, checked and decoded as the streamer does
// (decodeSectorPayload). Error: names the archive and the sector.
Result<Sector> readSector(const OpenedArchive& a, SectorKey key);

}  // namespace drtv::app
