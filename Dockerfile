# hapticd on Debian 12: the server, the device proxy, the impairment relay and the plain
# UDP echo the latency benchmarks compare with, built in
# a first stage and copied into a small runtime image (libraries only, no compiler).
# Layered so that a code change rebuilds only the code: the build stage's packages come
# first, from their own layer. Base images: `FROM debian:12`; where no registry can be
# reached, deploy/containers.sh builds it locally (debootstrap) and builds this file.
FROM debian:12 AS build
RUN apt-get update -qq \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      build-essential cmake ninja-build pkg-config libasio-dev libprotobuf-dev protobuf-compiler \
      libembree-dev libeigen3-dev rapidjson-dev libfmt-dev libssl-dev libsodium-dev >/dev/null \
 && rm -rf /var/lib/apt/lists/*
WORKDIR /opt/hapticd
COPY CMakeLists.txt ./
# the version (CMakeLists.txt reads it from the Python package's pyproject.toml)
COPY clients/python/pyproject.toml clients/python/
COPY proto proto
COPY server server
COPY clients/cpp clients/cpp
COPY bench/CMakeLists.txt bench/udp_echo_main.cc bench/
RUN cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DHAPTICD_BUILD_TESTS=OFF \
      -DHAPTICD_BUILD_BENCHMARKS=OFF >/dev/null \
 && ninja -C build hapticd hapticd-proxy hapticd-netem hapticd-udp-echo \
 && strip build/bin/hapticd build/bin/hapticd-proxy build/bin/hapticd-netem build/bin/hapticd-udp-echo

FROM debian:12
RUN apt-get update -qq \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      libprotobuf32 libembree3-3 libsodium23 libfmt9 libssl3 >/dev/null \
 && rm -rf /var/lib/apt/lists/*
COPY --from=build /opt/hapticd/build/bin/hapticd /opt/hapticd/build/bin/hapticd-proxy \
     /opt/hapticd/build/bin/hapticd-netem /opt/hapticd/build/bin/hapticd-udp-echo /usr/local/bin/
# The server, reachable from outside the container only with TLS and a token:
#   podman run -p 7460:7460 -p 7461:7461/udp -v $PWD/secrets:/secrets:ro IMAGE \
#     --host 0.0.0.0 --tls-cert /secrets/cert.pem --tls-key /secrets/key.pem \
#     --access-token-file /secrets/token
# The same image runs the others: --entrypoint hapticd-proxy (hapticd-netem, hapticd-udp-echo).
EXPOSE 7460 7461/udp
ENTRYPOINT ["hapticd"]
