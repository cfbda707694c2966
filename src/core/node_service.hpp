// Base of the services a Node owns (NMT, LSS, SDO, PDO, ...): the node they
// serve. Copying a service copies its state; an assigned service goes on
// serving its own node. So a service's whole state is saved and brought back
// with its implicit copy operations (NodeSnapshot), and a member added to a
// service is part of it without further code.
#pragma once

namespace cansim {

class Node;

class NodeService {
 protected:
  explicit NodeService(Node& node) : node_(node) {}
  NodeService(const NodeService&) = default;
  NodeService& operator=(const NodeService&) { return *this; }  // the node stays
  ~NodeService() = default;

  Node& node_;
};

}  // namespace cansim
