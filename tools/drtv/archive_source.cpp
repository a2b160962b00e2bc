// Archive by path or URL (archive_source.h).
#include "archive_source.h"

#include <algorithm>
#include <cctype>

#if DRTV_HAVE_NETSOURCE
#include "drtv/netsource/http_source.h"
#endif

namespace drtv::app {

bool isArchiveUrl(const std::string& s) {
  std::string head = s.substr(0, 8);
  std::transform(head.begin(), head.end(), head.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return head.starts_with("http://") || head.starts_with("https://");
}

Result<OpenedArchive> openArchive(const std::string& path_or_url, int http_connections) {
  OpenedArchive a;
  if (isArchiveUrl(path_or_url)) {
#if DRTV_HAVE_NETSOURCE
    netsource::HttpOptions o;
    o.max_connections = std::max(1, http_connections);
    auto http = netsource::HttpSectorSource::open(path_or_url, o);
    if (!http) return std::unexpected(http.error());
    std::shared_ptr<netsource::HttpSectorSource> source(std::move(*http));
    a.manifest = source->manifest();
    a.source = source;
    a.http = true;
    a.http_stats = [source] {
      const netsource::HttpStats st = source->stats();
      return std::to_string(st.requests) + " requests on " + std::to_string(st.connections) + " connections, " + std::to_string(st.retries) + " retries, " + std::to_string(st.failures) +
             " failed reads, " + std::to_string(st.bytes) + " payload bytes";
    };
    return a;
#else
    return fail(path_or_url + ": this drtv was built without drtv::netsource (DRTV_HTTP_SOURCE=OFF): it reads archives from files only");
#endif
  }
  auto reader = ArchiveReader::open(path_or_url);
  if (!reader) return std::unexpected(reader.error());
  a.manifest = reader->manifest();
  auto file = streamer::FileSectorSource::open(path_or_url);
  if (!file) return std::unexpected(file.error());
  a.source = std::shared_ptr<streamer::SectorSource>(std::move(*file));
  return a;
}

Result<Sector> readSector(const OpenedArchive& a, SectorKey key) {
  const std::string where = a.source->name() + ": sector " + toString(key);
  const SectorEntry* e = a.manifest.find(key);
  if (!e) return fail(where + ": not in this archive");
  auto bytes = a.source->read(*e);
  if (!bytes) return std::unexpected(bytes.error());
  return decodeSectorPayload(*e, *bytes, where);
}

}  // namespace drtv::app
