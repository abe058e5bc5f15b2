// Uploading a local map version to a pl-server: only the tiles it lacks, then publish.
#pragma once

#include <cstdint>
#include <string>

namespace pl::maps {

struct PushOptions {
  std::string db, map, server, token;
  std::int64_t version = 0;
  std::string ca_file;         // https: the CA the server's certificate must chain to; empty: the system's
  bool insecure_http = false;  // allow plain http:// to another machine (the token crosses in clear)
  std::string signing_key;     // PEM file of an Ed25519 private key: the version is published signed
};

struct PushReport {
  std::int64_t remote_version = 0;
  std::size_t tiles = 0, uploaded = 0, skipped = 0, deleted = 0;
  std::size_t bytes = 0;
  bool places = false;  // the local version's places were uploaded (else the remote copy's removed)
};

// Opens a staged version on the server (a copy of its current one), uploads the local version's
// tiles whose content the server's copy does not have, deletes the tiles the local version lacks,
// replaces the places with the local version's (or removes them), and publishes. Creates the map on the server when it is missing (that needs an admin token).
// With a signing key, the server's manifest of the new version must be the local version's (same
// tiles, hashes, places, origin and grid; else nothing is published), and is signed with the key.
// Throws pl::Error with the server's answer when a step fails; an unpublished staged version left
// on the server by a failed push stays invisible to readers.
PushReport push_version(const PushOptions& o);

}  // namespace pl::maps
