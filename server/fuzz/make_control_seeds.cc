// make_control_seeds REQUESTS.txt OUTDIR: the seed corpus of fuzz_control. Reads one
// hapticd.v1.Request per line in protobuf text format ('#' lines are comments) and
// writes each as one control frame (control_frame.h), request-NN, plus all of them in
// order as one connection, connection-all.

#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <google/protobuf/text_format.h>

#include "hapticd/v1/hapticd.pb.h"
#include "server/net/control_frame.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: " << argv[0] << " REQUESTS.txt OUTDIR\n";
    return 2;
  }
  std::ifstream in(argv[1]);
  if (!in) {
    std::cerr << argv[1] << ": cannot be read\n";
    return 1;
  }
  const std::string out_dir = argv[2];
  const auto write = [&](const std::string& name, const std::string& bytes) {
    std::ofstream(out_dir + "/" + name, std::ios::binary) << bytes;
  };
  std::string line;
  std::string connection;
  int line_number = 0;
  int count = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty() || line[0] == '#') continue;
    hapticd::v1::Request request;
    if (!google::protobuf::TextFormat::ParseFromString(line, &request)) {
      std::cerr << argv[1] << ":" << line_number << ": not a hapticd.v1.Request in text format\n";
      return 1;
    }
    const std::string frame = hapticd::net::EncodeFrame(request);
    char name[32];
    std::snprintf(name, sizeof name, "request-%02d", ++count);
    write(name, frame);
    connection += frame;
  }
  write("connection-all", connection);
  std::cout << "make_control_seeds: " << count << " requests\n";
  return 0;
}
