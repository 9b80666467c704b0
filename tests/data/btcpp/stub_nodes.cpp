// Stub nodes for loading and ticking exported trees in the real BehaviorTree.CPP v4.
//
// Compiled by tests/test_btcpp_real.py against the headers of the behaviortreepy sdist and linked
// to the BT.CPP library inside its wheel (both from PyPI, same release), then loaded with ctypes
// into the test's Python process. behaviortreepy's own Python API registers nodes without ports,
// so it cannot load a tree whose nodes have ports; this file registers each node of the exported
// <TreeNodesModel> with its typed input ports and defaults, as a C++ user's providedPorts() would.
//
// Every stub reads every input port the XML (or a port default) gives it, through BT.CPP's own
// getInput<T>() (so literals are converted by the port's type and `{key}` remappings are resolved
// through the subtree blackboards), logs the values, and returns SUCCESS: a port BT.CPP cannot
// resolve is an error of the run, not a silent default.
//
// Spec lines (tab-separated): N <Action|Condition|Decorator|Control> <ID>;
// P <port> <type> <0|1 has default> [default]; B <key> <double|bool|string> <value>;
// F <name>: the stub nodes of that instance name return FAILURE (all others SUCCESS);
// E <element id>: the design's elements in build order (what an empty ForEachElement runs over).
//
// fvtree's own kinds are modelled, not stubbed: ForEachElement runs its child once per element,
// StatusMap maps its child's status, FvParallel ticks every child as py_trees' Parallel does.
// A guard is exported as BT.CPP's own ReactiveSequence of its condition and its child: not stubbed.

#include <behaviortree_cpp/bt_factory.h>
#include <behaviortree_cpp/xml_parsing.h>

#include <algorithm>
#include <cstdio>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace
{
using namespace BT;

std::string g_result;
std::ostringstream g_log;
std::set<std::string> g_failing;  // instance names whose stubs fail

NodeStatus outcome(const TreeNode& node)
{
  return g_failing.count(node.name()) ? NodeStatus::FAILURE : NodeStatus::SUCCESS;
}

std::vector<std::string> fields(const std::string& line)
{
  std::vector<std::string> out;
  std::string::size_type start = 0;
  while(true)
  {
    auto tab = line.find('\t', start);
    out.push_back(line.substr(start, tab == std::string::npos ? std::string::npos : tab - start));
    if(tab == std::string::npos)
      return out;
    start = tab + 1;
  }
}

std::string number(double v)
{
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

template <typename T>
std::string read(TreeNode& node, const std::string& port)
{
  auto value = node.getInput<T>(port);
  if(!value)
    throw RuntimeError(node.fullPath(), ": input port [", port, "]: ", value.error());
  if constexpr(std::is_same_v<T, double>)
    return number(value.value());
  else if constexpr(std::is_same_v<T, int>)
    return std::to_string(value.value());
  else if constexpr(std::is_same_v<T, bool>)
    return value.value() ? "true" : "false";
  else if constexpr(std::is_same_v<T, std::string>)
    return value.value();
  else
  {
    std::string out;
    for(const auto& item : value.value())
    {
      if(!out.empty())
        out += ";";
      if constexpr(std::is_same_v<T, std::vector<double>>)
        out += number(item);
      else
        out += item;
    }
    return out;
  }
}

// Reads every input port the node was given (an empty string is an optional port left out) and
// logs "TICK <path> <ID> port=value ..." for the test to compare with fvtree's own arguments.
void read_all(TreeNode& node)
{
  const auto& config = static_cast<const TreeNode&>(node).config();
  g_log << "TICK\t" << node.fullPath() << "\t" << node.registrationName();
  for(const auto& [port, info] : config.manifest->ports)
  {
    auto given = config.input_ports.find(port);
    if(given == config.input_ports.end() || given->second.empty())
      continue;
    const auto& type = info.type();
    std::string text;
    if(type == typeid(double))
      text = read<double>(node, port);
    else if(type == typeid(int))
      text = read<int>(node, port);
    else if(type == typeid(bool))
      text = read<bool>(node, port);
    else if(type == typeid(std::vector<double>))
      text = read<std::vector<double>>(node, port);
    else if(type == typeid(std::vector<std::string>))
      text = read<std::vector<std::string>>(node, port);
    else
      text = read<std::string>(node, port);
    g_log << "\t" << port << "=" << text;
  }
  g_log << "\n";
}

class StubAction : public SyncActionNode
{
public:
  StubAction(const std::string& name, const NodeConfig& config) : SyncActionNode(name, config) {}
  NodeStatus tick() override
  {
    read_all(*this);
    return outcome(*this);
  }
};

class StubCondition : public ConditionNode
{
public:
  StubCondition(const std::string& name, const NodeConfig& config) : ConditionNode(name, config) {}
  NodeStatus tick() override
  {
    read_all(*this);
    return outcome(*this);
  }
};

// A decorator that returns its child's status (a plug-in's decorator).
class StubDecorator : public DecoratorNode
{
public:
  StubDecorator(const std::string& name, const NodeConfig& config) : DecoratorNode(name, config) {}
  NodeStatus tick() override
  {
    if(status() == NodeStatus::IDLE)
      read_all(*this);
    setStatus(NodeStatus::RUNNING);
    const NodeStatus out = child_node_->executeTick();
    if(out != NodeStatus::RUNNING)
      resetChild();
    return out;
  }
};

// A control that ticks its children in order, as a sequence with memory (a plug-in's control).
class StubControl : public ControlNode
{
public:
  StubControl(const std::string& name, const NodeConfig& config) : ControlNode(name, config) {}
  NodeStatus tick() override
  {
    if(status() == NodeStatus::IDLE)
    {
      read_all(*this);
      index_ = 0;
    }
    setStatus(NodeStatus::RUNNING);
    while(index_ < childrenCount())
    {
      const NodeStatus out = children_nodes_[index_]->executeTick();
      if(out == NodeStatus::RUNNING)
        return out;
      if(out == NodeStatus::FAILURE)
      {
        resetChildren();
        index_ = 0;
        return out;
      }
      index_++;
    }
    resetChildren();
    index_ = 0;
    return NodeStatus::SUCCESS;
  }
  void halt() override
  {
    index_ = 0;
    ControlNode::halt();
  }

private:
  size_t index_ = 0;
};

std::vector<std::string> g_elements;  // the design's elements in build order (spec lines E)

std::vector<std::string> split(const std::string& text, char sep)
{
  std::vector<std::string> out;
  std::string::size_type start = 0;
  while(start <= text.size())
  {
    auto end = text.find(sep, start);
    if(end == std::string::npos)
      end = text.size();
    if(end > start)
      out.push_back(text.substr(start, end - start));
    start = end + 1;
  }
  return out;
}

// fvtree's for_each_element: the child once per element (the `elements` port, or every element of
// the design when it is empty), in order; FAILURE as soon as one fails. Logs "ELEMENT <path> <id>".
class ForEachElementStub : public DecoratorNode
{
public:
  ForEachElementStub(const std::string& name, const NodeConfig& config) : DecoratorNode(name, config) {}
  NodeStatus tick() override
  {
    if(status() == NodeStatus::IDLE)
    {
      read_all(*this);
      auto given = getInput<std::vector<std::string>>("elements");
      elements_ = given && !given.value().empty() ? given.value() : g_elements;
      index_ = 0;
      started_ = false;
    }
    setStatus(NodeStatus::RUNNING);
    while(index_ < elements_.size())
    {
      if(!started_)
      {
        g_log << "ELEMENT\t" << fullPath() << "\t" << elements_[index_] << "\n";
        started_ = true;
      }
      const NodeStatus out = child_node_->executeTick();
      if(out == NodeStatus::RUNNING)
        return out;
      resetChild();
      started_ = false;
      if(out == NodeStatus::FAILURE)
      {
        index_ = 0;
        return out;
      }
      index_++;
    }
    index_ = 0;
    return NodeStatus::SUCCESS;
  }
  void halt() override
  {
    index_ = 0;
    started_ = false;
    DecoratorNode::halt();
  }

private:
  std::vector<std::string> elements_;
  size_t index_ = 0;
  bool started_ = false;
};

NodeStatus fvtree_status(const std::string& name)
{
  if(name == "success")
    return NodeStatus::SUCCESS;
  if(name == "failure")
    return NodeStatus::FAILURE;
  if(name == "running")
    return NodeStatus::RUNNING;
  throw RuntimeError("StatusMap: unknown status [", name, "]");
}

// fvtree's status_map: the child's status translated through `map` ("from:to;...").
class StatusMapStub : public DecoratorNode
{
public:
  StatusMapStub(const std::string& name, const NodeConfig& config) : DecoratorNode(name, config) {}
  NodeStatus tick() override
  {
    if(status() == NodeStatus::IDLE)
      read_all(*this);
    setStatus(NodeStatus::RUNNING);
    const NodeStatus out = child_node_->executeTick();
    NodeStatus mapped = out;
    for(const auto& pair : split(getInput<std::string>("map").value(), ';'))
    {
      auto sides = split(pair, ':');
      if(sides.size() != 2)
        throw RuntimeError("StatusMap: bad pair [", pair, "]");
      if(fvtree_status(sides[0]) == out)
        mapped = fvtree_status(sides[1]);
    }
    if(out != NodeStatus::RUNNING)
      resetChild();
    return mapped;
  }
};

// fvtree's parallel (py_trees' Parallel): every child ticked each tick (with `synchronise`, those
// that succeeded are not ticked again), then FAILURE if one failed; SUCCESS when all (policy all),
// one (one), or the `selected` children by name (selected) have succeeded.
class FvParallelStub : public ControlNode
{
public:
  FvParallelStub(const std::string& name, const NodeConfig& config) : ControlNode(name, config) {}
  NodeStatus tick() override
  {
    if(status() == NodeStatus::IDLE)
    {
      read_all(*this);
      done_.assign(childrenCount(), NodeStatus::IDLE);
    }
    setStatus(NodeStatus::RUNNING);
    const std::string policy = getInput<std::string>("policy").value();
    const bool synchronise = getInput<bool>("synchronise").value();
    auto chosen = getInput<std::vector<std::string>>("selected");
    const std::vector<std::string> selected = chosen ? chosen.value() : std::vector<std::string>{};
    bool failed = false;
    for(size_t i = 0; i < childrenCount(); i++)  // every child, then the verdict (py_trees' order)
    {
      if(synchronise && done_[i] == NodeStatus::SUCCESS)
        continue;
      done_[i] = children_nodes_[i]->executeTick();
      failed = failed || done_[i] == NodeStatus::FAILURE;
    }
    if(failed)
      return finish(NodeStatus::FAILURE);
    size_t succeeded = 0, wanted = 0, wanted_succeeded = 0;
    for(size_t i = 0; i < childrenCount(); i++)
    {
      const bool ok = done_[i] == NodeStatus::SUCCESS;
      succeeded += ok;
      if(std::find(selected.begin(), selected.end(), children_nodes_[i]->name()) != selected.end())
      {
        wanted++;
        wanted_succeeded += ok;
      }
    }
    if((policy == "all" && succeeded == childrenCount()) || (policy == "one" && succeeded > 0) ||
       (policy == "selected" && wanted_succeeded == wanted))
      return finish(NodeStatus::SUCCESS);
    return NodeStatus::RUNNING;
  }
  void halt() override
  {
    done_.assign(childrenCount(), NodeStatus::IDLE);
    ControlNode::halt();
  }

private:
  NodeStatus finish(NodeStatus result)
  {
    resetChildren();
    done_.assign(childrenCount(), NodeStatus::IDLE);
    return result;
  }
  std::vector<NodeStatus> done_;
};

PortInfo typed_port(const std::string& name, const std::string& type)
{
  if(type == "double")
    return InputPort<double>(name).second;
  if(type == "int")
    return InputPort<int>(name).second;
  if(type == "bool")
    return InputPort<bool>(name).second;
  if(type == "std::vector<double>")
    return InputPort<std::vector<double>>(name).second;
  if(type == "std::vector<std::string>")
    return InputPort<std::vector<std::string>>(name).second;
  if(type == "std::string")
    return InputPort<std::string>(name).second;
  throw RuntimeError("no C++ type for port type [", type, "]");
}

template <typename NodeT>
NodeBuilder builder()
{
  return [](const std::string& name, const NodeConfig& config) {
    return std::make_unique<NodeT>(name, config);
  };
}

// Registers the spec's nodes in `factory` and sets its blackboard lines on `blackboard` (if any).
void register_spec(BehaviorTreeFactory& factory, const std::string& spec,
                   const Blackboard::Ptr& blackboard)
{
  std::istringstream lines(spec);
  std::string line;
  g_failing.clear();
  g_elements.clear();
  std::vector<TreeNodeManifest> manifests;
  while(std::getline(lines, line))
  {
    if(line.empty())
      continue;
    auto f = fields(line);
    if(f[0] == "N" && f.size() == 3)
    {
      TreeNodeManifest manifest;
      manifest.type = convertFromString<NodeType>(f[1]);
      manifest.registration_ID = f[2];
      manifests.push_back(manifest);
    }
    else if(f[0] == "P" && f.size() >= 4 && !manifests.empty())
    {
      PortInfo info = typed_port(f[1], f[2]);
      if(f[3] == "1")
        info.setDefaultValue(f.size() > 4 ? f[4] : std::string());
      manifests.back().ports.insert({ f[1], info });
    }
    else if(f[0] == "F" && f.size() == 2)
      g_failing.insert(f[1]);
    else if(f[0] == "E" && f.size() == 2)
      g_elements.push_back(f[1]);
    else if(f[0] == "B" && f.size() == 4)
    {
      if(blackboard == nullptr)
        continue;
      if(f[2] == "double")
        blackboard->set(f[1], convertFromString<double>(f[3]));
      else if(f[2] == "bool")
        blackboard->set(f[1], f[3] == "true");
      else
        blackboard->set(f[1], f[3]);
    }
    else
      throw RuntimeError("bad spec line [", line, "]");
  }
  for(const auto& manifest : manifests)
  {
    // fvtree's own kinds, modelled
    if(manifest.registration_ID == "ForEachElement")
    {
      factory.registerBuilder(manifest, builder<ForEachElementStub>());
      continue;
    }
    if(manifest.registration_ID == "StatusMap")
    {
      factory.registerBuilder(manifest, builder<StatusMapStub>());
      continue;
    }
    if(manifest.registration_ID == "FvParallel")
    {
      factory.registerBuilder(manifest, builder<FvParallelStub>());
      continue;
    }
    switch(manifest.type)
    {
      case NodeType::ACTION:
        factory.registerBuilder(manifest, builder<StubAction>());
        break;
      case NodeType::CONDITION:
        factory.registerBuilder(manifest, builder<StubCondition>());
        break;
      case NodeType::DECORATOR:
        factory.registerBuilder(manifest, builder<StubDecorator>());
        break;
      case NodeType::CONTROL:
        factory.registerBuilder(manifest, builder<StubControl>());
        break;
      default:
        throw RuntimeError("cannot stub a node of type ", toStr(manifest.type));
    }
  }
}

}  // namespace

extern "C" {

// Loads `xml` with the spec's stubs registered and ticks it until it stops running (at most
// `max_ticks` ticks). Returns "STATUS <status> <ticks>\n" and the stubs' TICK lines, or
// "ERROR\t<what BT.CPP said>".
const char* fv_btcpp_run(const char* spec, const char* xml, int max_ticks)
{
  g_log.str("");
  try
  {
    BehaviorTreeFactory factory;
    auto blackboard = Blackboard::create();
    register_spec(factory, spec, blackboard);
    auto tree = factory.createTreeFromText(xml, blackboard);
    NodeStatus status = NodeStatus::RUNNING;
    int ticks = 0;
    while(status == NodeStatus::RUNNING && ticks < max_ticks)
    {
      status = tree.tickOnce();
      ticks++;
    }
    tree.haltTree();
    g_result = "STATUS\t" + toStr(status) + "\t" + std::to_string(ticks) + "\n" + g_log.str();
  }
  catch(const std::exception& exc)
  {
    g_result = std::string("ERROR\t") + exc.what();
  }
  return g_result.c_str();
}

// The tree as BT.CPP's Groot2Publisher sends it to Groot2 (its FULLTREE reply): `xml` loaded with
// the spec's stubs and written back by WriteTreeToXML with metadata (_uid, _fullpath) and models.
const char* fv_btcpp_fulltree(const char* spec, const char* xml)
{
  try
  {
    BehaviorTreeFactory factory;
    auto blackboard = Blackboard::create();
    register_spec(factory, spec, blackboard);
    auto tree = factory.createTreeFromText(xml, blackboard);
    g_result = WriteTreeToXML(tree, true, true);
  }
  catch(const std::exception& exc)
  {
    g_result = std::string("ERROR\t") + exc.what();
  }
  return g_result.c_str();
}

// The XSD that BT.CPP writes (writeTreeXSD) for a factory with the spec's nodes registered.
const char* fv_btcpp_xsd(const char* spec)
{
  try
  {
    BehaviorTreeFactory factory;
    register_spec(factory, spec, nullptr);
    g_result = writeTreeXSD(factory);
  }
  catch(const std::exception& exc)
  {
    g_result = std::string("ERROR\t") + exc.what();
  }
  return g_result.c_str();
}

// BT.CPP's library version, to tell in a test report which BT.CPP ran.
const char* fv_btcpp_version()
{
  g_result = LibraryVersionString();
  return g_result.c_str();
}
}
