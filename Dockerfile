# hapticd on Debian 12. The image runs the same install and build scripts that CI
# proves on a bare machine (deploy/install.sh, deploy/build.sh).
FROM debian:12
WORKDIR /opt/hapticd
COPY . .
RUN bash deploy/install.sh && bash deploy/build.sh normal
# Until the server exists, the image answers geometry conformance cases on stdin:
#   docker run -i IMAGE < cases.jsonl
ENTRYPOINT ["build/bin/hapticd-query"]
