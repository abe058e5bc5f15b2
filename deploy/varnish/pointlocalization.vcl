# Varnish 7.1 (Debian 12: apt-get install varnish) as a cache in front of pl-server replicas.
# Fill in @ORIGIN_HOST@ and @ORIGIN_PORT@ (a replica's plain-HTTP address, e.g. 127.0.0.1 and 8080),
# add a backend per further replica (see pl2 below), then run it, for instance:
#   varnishd -a :6081 -f /etc/varnish/pointlocalization.vcl -s malloc,2G
# tests/deploy/cache_tier.sh starts it on loopback in front of a real pl-server and checks what
# follows; docs/cache-tier.md is the operator's side of it.
#
# What pl-server's answers say, and so what this cache does:
#   - bytes named by their SHA-256 (blobs; a published version's tiles, places and signed manifest):
#     "public, max-age=31536000, immutable". Kept a year, never revalidated: they cannot change.
#   - the map list, a map's manifest, ROI answers, a version's tile list: "public, max-age=1" and a
#     weak ETag. Kept one second, then revalidated with If-None-Match (the origin answers 304 while
#     the body is the same), so a publish shows through the cache within about a second.
#   - requests with a token (uploads, staged versions): never answered from nor stored in the cache.
# Many vehicles asking at once for an object not yet cached (or just expired) wait for one origin
# request: Varnish's request coalescing, which needs those requests to reach a lookup (no pass).

vcl 4.1;

import directors;
import std;

# /readyz is 503 while a replica drains or cannot reach its map store: the director then leaves that
# replica out, and while no replica is ready the map answers are served stale (vcl_recv).
probe pl_ready {
  .url = "/readyz";
  .interval = 1s;
  .timeout = 1s;
  .window = 3;
  .threshold = 2;
  .initial = 2;  # healthy from the start: a restarted cache must not begin by refusing everything
}

backend pl1 {
  .host = "@ORIGIN_HOST@";
  .port = "@ORIGIN_PORT@";
  .probe = pl_ready;
  .connect_timeout = 2s;
  .first_byte_timeout = 60s;  # a 64 MiB upload is decoded and checked before pl-server answers
  .between_bytes_timeout = 30s;
}

# backend pl2 {
#   .host = "10.0.0.12";
#   .port = "8080";
#   .probe = pl_ready;
#   .connect_timeout = 2s;
#   .first_byte_timeout = 60s;
#   .between_bytes_timeout = 30s;
# }

sub vcl_init {
  new origin = directors.round_robin();
  origin.add_backend(pl1);
  # origin.add_backend(pl2);
}

sub vcl_recv {
  set req.backend_hint = origin.backend();

  # Our own marker for a request restarted after the origin failed (vcl_synth); a client's is void.
  if (req.restarts == 0) {
    unset req.http.X-PL-Stale-If-Error;
  }

  # Writes, and reads with a token, are the token holder's business: straight to the origin, bodies
  # streamed (uploads go up to 64 MiB), nothing kept.
  if (req.method != "GET" && req.method != "HEAD") {
    return (pass);
  }
  if (req.http.Authorization) {
    return (pass);
  }
  # Health and metrics (all that is outside /v1/) describe the replica that answers them, at the
  # time it answers.
  if (req.url !~ "^/v1/") {
    return (pass);
  }

  # pl-server sets no cookies and reads none: a client's cookie is no reason to bypass the cache
  # (Varnish's built-in rules would), and is not passed on.
  unset req.http.Cookie;

  # While a replica is ready, an expired map answer is fetched again (conditionally) before it is
  # served, so that what vehicles see lags a publish by a second at most. Only while none is ready,
  # or right after the origin failed on this very object, is the stale copy served (grace, below).
  if (std.healthy(req.backend_hint) && !req.http.X-PL-Stale-If-Error) {
    set req.grace = 0s;
  } else {
    # No limit but the object's own grace. (Said explicitly: a restart keeps the 0s set above.)
    set req.grace = 1d;
  }
  return (hash);
}

sub vcl_hash {
  # The path and the query (an ROI query's x, y, radius, version and have= make it another object),
  # not the Host: vehicles reaching the cache by IP address or by name share one copy.
  hash_data(req.url);
  return (lookup);
}

sub vcl_backend_fetch {
  if (bereq.http.X-PL-Stale-If-Error) {
    # The origin has just failed on this object and the client is being served the stale copy:
    # the refresh that serving it starts would ask the failing origin again at once. Leave it to
    # the next request.
    if (bereq.is_bgfetch) {
      return (abandon);
    }
    # No stale copy was left to serve: fetch afresh (the answer, error or not, goes to the client).
    unset bereq.http.If-None-Match;
    unset bereq.http.X-PL-Stale-If-Error;
  }
}

sub vcl_backend_response {
  if (bereq.uncacheable) {
    return (deliver);
  }

  if (beresp.status >= 500) {
    # A refresh in the background that fails keeps the stale copy in service. So does one a client
    # waits for, when there is a copy to fall back on (Varnish asked conditionally, with its ETag):
    # abandoning it sends that client through vcl_synth, which restarts it allowing full grace.
    if (bereq.is_bgfetch || bereq.http.If-None-Match) {
      return (abandon);
    }
    # Otherwise the error goes out, and stays a second: long enough that a crowd waiting on it is
    # answered from it rather than each asking the failing origin in turn, short enough to recover.
    set beresp.ttl = 1s;
    set beresp.grace = 0s;
    set beresp.keep = 0s;
    return (deliver);
  }

  if (beresp.http.Set-Cookie || beresp.http.Vary == "*" ||
      beresp.http.Cache-Control ~ "(?i)(private|no-store|no-cache)") {
    # Not something pl-server sends to a request without a token; should it ever, the object is
    # not shared, and the "hit-for-miss" marker lasts only a second so coalescing resumes soon.
    set beresp.ttl = 1s;
    set beresp.uncacheable = true;
    return (deliver);
  }

  if (!beresp.http.Cache-Control) {
    # Answers that name no lifetime (errors: 404 for a map or version not there yet, 400, ...) are
    # kept one second, like the map answers: the default (two minutes) would hide a newly created
    # map or published version for that long.
    set beresp.ttl = 1s;
  }

  # Grace: how long past its lifetime an answer may still be served while the origin is out of
  # reach. Immutable objects never reach it (a year's lifetime); for the one-second map answers it
  # rides out a replica restart or a store fail-over, and is short enough that a real outage shows
  # as errors to the fleet's monitoring rather than being hidden for long.
  set beresp.grace = 30s;
  return (deliver);
}

sub vcl_backend_error {
  # A replica that could not be reached (killed, restarting, before its probe marks it sick): a
  # read is asked once more, and the round-robin director sends it to the next replica. A write is
  # not repeated (it may have reached the replica).
  if (bereq.retries == 0 && (bereq.method == "GET" || bereq.method == "HEAD")) {
    return (retry);
  }
  # The origin could not be reached at all (refused, timed out, no replica ready): as for a 5xx.
  if (!bereq.uncacheable && (bereq.is_bgfetch || bereq.http.If-None-Match)) {
    return (abandon);
  }
  # pl-server's own error shape, so clients parse this one like the others.
  set beresp.http.Content-Type = "application/json";
  set beresp.http.Retry-After = "1";
  set beresp.body = {"{"error":"the map server is unreachable just now: retry in a second","status":"} +
                    beresp.status + "}";
  return (deliver);
}

sub vcl_synth {
  # A fetch abandoned above (the origin failed on a GET that had a stale copy): look again, this
  # time allowing the whole grace, which finds the stale copy. Once only: a second failure is
  # answered as an error.
  if (resp.status == 503 && req.restarts == 0 && (req.method == "GET" || req.method == "HEAD") &&
      !req.http.Authorization && req.url ~ "^/v1/") {
    set req.http.X-PL-Stale-If-Error = "1";
    return (restart);
  }
  set resp.http.Content-Type = "application/json";
  set resp.http.Retry-After = "1";
  set resp.body = {"{"error":"the map cache could not answer: retry in a second","status":"} + resp.status + "}";
  return (deliver);
}

sub vcl_deliver {
  # For operators and tests: how this answer was made. "stale" means past its lifetime (grace).
  if (obj.uncacheable) {
    set resp.http.X-Cache = "pass";
  } else if (obj.hits > 0 && obj.ttl < 0s) {
    set resp.http.X-Cache = "stale";
  } else if (obj.hits > 0) {
    set resp.http.X-Cache = "hit";
  } else {
    set resp.http.X-Cache = "miss";
  }
}
