# hapticd on Debian 12. The image runs the same install and build scripts that CI
# proves on a bare machine (deploy/install.sh, deploy/build.sh).
FROM debian:12
WORKDIR /opt/hapticd
COPY . .
RUN bash deploy/install.sh && bash deploy/build.sh normal
# The server, reachable from outside the container only with TLS and a token:
#   docker run -p 7460:7460 -p 7461:7461/udp -v $PWD/secrets:/secrets IMAGE \
#     --host 0.0.0.0 --tls-cert /secrets/cert.pem --tls-key /secrets/key.pem \
#     --access-token-file /secrets/token
EXPOSE 7460 7461/udp
ENTRYPOINT ["build/bin/hapticd"]
