// SPDX-License-Identifier: MIT
// somm_gpu — Vulkan compute harness: loader opened with dlopen, one compute queue, host-visible buffers, the
// embedded SPIR-V kernels (built from src/gpu/kernels/ with shaders/somm.glsl / somm.hlsl).
#define VK_NO_PROTOTYPES
#include <dlfcn.h>
#include <vulkan/vulkan.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <string>
#include <utility>

#include "somm/gpu.h"
#include "somm_check_glsl.h"  // generated: const uint32_t somm_check_glsl[]
#include "somm_check_hlsl.h"  // generated: const uint32_t somm_check_hlsl[]

namespace somm::gpu {

const char* shaderLanguageName(ShaderLanguage l) noexcept {
  return l == ShaderLanguage::Glsl ? "glsl" : "hlsl";
}

namespace {

#define SOMM_VK_INSTANCE_FNS(X)               \
  X(vkDestroyInstance)                        \
  X(vkEnumeratePhysicalDevices)               \
  X(vkGetPhysicalDeviceProperties)            \
  X(vkGetPhysicalDeviceQueueFamilyProperties) \
  X(vkGetPhysicalDeviceMemoryProperties)      \
  X(vkCreateDevice)                           \
  X(vkGetDeviceProcAddr)

#define SOMM_VK_DEVICE_FNS(X)      \
  X(vkDestroyDevice)               \
  X(vkDeviceWaitIdle)              \
  X(vkGetDeviceQueue)              \
  X(vkCreateBuffer)                \
  X(vkDestroyBuffer)               \
  X(vkGetBufferMemoryRequirements) \
  X(vkAllocateMemory)              \
  X(vkFreeMemory)                  \
  X(vkBindBufferMemory)            \
  X(vkMapMemory)                   \
  X(vkUnmapMemory)                 \
  X(vkCreateShaderModule)          \
  X(vkDestroyShaderModule)         \
  X(vkCreateDescriptorSetLayout)   \
  X(vkDestroyDescriptorSetLayout)  \
  X(vkCreatePipelineLayout)        \
  X(vkDestroyPipelineLayout)       \
  X(vkCreateComputePipelines)      \
  X(vkDestroyPipeline)             \
  X(vkCreateDescriptorPool)        \
  X(vkDestroyDescriptorPool)       \
  X(vkAllocateDescriptorSets)      \
  X(vkUpdateDescriptorSets)        \
  X(vkCreateCommandPool)           \
  X(vkDestroyCommandPool)          \
  X(vkAllocateCommandBuffers)      \
  X(vkBeginCommandBuffer)          \
  X(vkEndCommandBuffer)            \
  X(vkCmdBindPipeline)             \
  X(vkCmdBindDescriptorSets)       \
  X(vkCmdPushConstants)            \
  X(vkCmdDispatch)                 \
  X(vkCmdPipelineBarrier)          \
  X(vkQueueSubmit)                 \
  X(vkCreateFence)                 \
  X(vkDestroyFence)                \
  X(vkWaitForFences)               \
  X(vkResetFences)

Error vkError(const std::string& what, VkResult r) {
  return makeError(ErrorCode::IoError,
                   "Vulkan: " + what + " failed (VkResult " + std::to_string(int(r)) + ")");
}

struct PushConstants {
  uint32_t base, count, mode, stride;
};

constexpr uint32_t kLocalSize = 64;      // local_size_x / numthreads of the kernels
constexpr uint32_t kMaxGroupsX = 65535;  // the guaranteed minimum of maxComputeWorkGroupCount[0]

}  // namespace

struct Device::Impl {
  void* lib = nullptr;
  PFN_vkGetInstanceProcAddr vkGetInstanceProcAddr = nullptr;
  PFN_vkCreateInstance vkCreateInstance = nullptr;
#define SOMM_DECLARE(f) PFN_##f f = nullptr;
  SOMM_VK_INSTANCE_FNS(SOMM_DECLARE)
  SOMM_VK_DEVICE_FNS(SOMM_DECLARE)
#undef SOMM_DECLARE

  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkPhysicalDeviceMemoryProperties memory{};
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t queueFamily = 0;
  std::string name;
  VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
  VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
  VkPipelineLayout pipelineLayout = VK_NULL_HANDLE;
  VkPipeline pipelines[2] = {VK_NULL_HANDLE, VK_NULL_HANDLE};
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkDescriptorSet set = VK_NULL_HANDLE;
  VkCommandPool commandPool = VK_NULL_HANDLE;
  VkCommandBuffer commands = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;

  struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    void* mapped = nullptr;
    VkDeviceSize size = 0;
  };

  ~Impl() {
    if (device) {
      vkDeviceWaitIdle(device);
      if (fence) vkDestroyFence(device, fence, nullptr);
      if (commandPool) vkDestroyCommandPool(device, commandPool, nullptr);
      if (pool) vkDestroyDescriptorPool(device, pool, nullptr);
      for (VkPipeline p : pipelines)
        if (p) vkDestroyPipeline(device, p, nullptr);
      if (pipelineLayout) vkDestroyPipelineLayout(device, pipelineLayout, nullptr);
      if (setLayout) vkDestroyDescriptorSetLayout(device, setLayout, nullptr);
      vkDestroyDevice(device, nullptr);
    }
    if (instance && vkDestroyInstance) vkDestroyInstance(instance, nullptr);
    if (lib) dlclose(lib);
  }

  Status init() {
#if defined(__SANITIZE_ADDRESS__)
    // LeakSanitizer: the loader unloads the driver at vkDestroyInstance, and what the driver's static data still
    // referenced then looks leaked, in frames of an "<unknown module>" that no suppression can name. Under ASan,
    // keep Mesa's lavapipe resident (if present) so that its memory stays reachable and attributable
    // (tests/gpu/lsan-mesa.supp).
    dlopen("libvulkan_lvp.so", RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
#endif
    lib = dlopen("libvulkan.so.1", RTLD_NOW | RTLD_LOCAL);
    if (!lib) lib = dlopen("libvulkan.so", RTLD_NOW | RTLD_LOCAL);
    if (!lib)
      return makeError(
          ErrorCode::UnsupportedFormat,
          "no Vulkan device: the Vulkan loader libvulkan.so.1 is not installed (Debian: libvulkan1, and "
          "mesa-vulkan-drivers for the lavapipe CPU device)");
    vkGetInstanceProcAddr = reinterpret_cast<PFN_vkGetInstanceProcAddr>(dlsym(lib, "vkGetInstanceProcAddr"));
    if (!vkGetInstanceProcAddr)
      return makeError(ErrorCode::UnsupportedFormat,
                       "no Vulkan device: libvulkan.so.1 has no vkGetInstanceProcAddr");
    vkCreateInstance =
        reinterpret_cast<PFN_vkCreateInstance>(vkGetInstanceProcAddr(nullptr, "vkCreateInstance"));
    if (!vkCreateInstance)
      return makeError(ErrorCode::UnsupportedFormat,
                       "no Vulkan device: the loader exports no vkCreateInstance");

    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "somm";
    app.pEngineName = "somm";
    app.apiVersion = VK_API_VERSION_1_0;
    VkInstanceCreateInfo ici{};
    ici.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    ici.pApplicationInfo = &app;
    if (VkResult r = vkCreateInstance(&ici, nullptr, &instance); r != VK_SUCCESS) {
      instance = VK_NULL_HANDLE;
      if (r == VK_ERROR_INCOMPATIBLE_DRIVER)
        return makeError(
            ErrorCode::UnsupportedFormat,
            "no Vulkan device: no Vulkan driver is installed (Debian: mesa-vulkan-drivers provides the "
            "lavapipe CPU device)");
      return vkError("vkCreateInstance", r);
    }
#define SOMM_LOAD_INSTANCE(f)                                           \
  (f) = reinterpret_cast<PFN_##f>(vkGetInstanceProcAddr(instance, #f)); \
  if (!f) return makeError(ErrorCode::UnsupportedFormat, "Vulkan: the loader has no " #f);
    SOMM_VK_INSTANCE_FNS(SOMM_LOAD_INSTANCE)
#undef SOMM_LOAD_INSTANCE

    uint32_t count = 0;
    if (VkResult r = vkEnumeratePhysicalDevices(instance, &count, nullptr);
        r != VK_SUCCESS && r != VK_INCOMPLETE)
      return vkError("vkEnumeratePhysicalDevices", r);
    std::vector<VkPhysicalDevice> devices(count);
    if (count) vkEnumeratePhysicalDevices(instance, &count, devices.data());
    devices.resize(count);
    // Prefer a real GPU over a CPU implementation; among equals, the first.
    int best = -1, bestRank = 99;
    uint32_t bestFamily = 0;
    for (size_t i = 0; i < devices.size(); ++i) {
      VkPhysicalDeviceProperties p;
      vkGetPhysicalDeviceProperties(devices[i], &p);
      uint32_t nf = 0;
      vkGetPhysicalDeviceQueueFamilyProperties(devices[i], &nf, nullptr);
      std::vector<VkQueueFamilyProperties> families(nf);
      vkGetPhysicalDeviceQueueFamilyProperties(devices[i], &nf, families.data());
      int family = -1;
      for (uint32_t f = 0; f < nf; ++f)
        if (families[f].queueFlags & VK_QUEUE_COMPUTE_BIT) {
          family = int(f);
          break;
        }
      if (family < 0) continue;
      const int rank = p.deviceType == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU     ? 0
                       : p.deviceType == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU ? 1
                       : p.deviceType == VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU    ? 2
                       : p.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU            ? 4
                                                                                : 3;
      if (rank < bestRank) best = int(i), bestRank = rank, bestFamily = uint32_t(family);
    }
    if (best < 0)
      return makeError(ErrorCode::UnsupportedFormat,
                       count == 0 ? "no Vulkan device: the Vulkan loader found no physical device (Debian: "
                                    "mesa-vulkan-drivers provides the lavapipe CPU device)"
                                  : "no Vulkan device with a compute queue");
    physical = devices[size_t(best)];
    queueFamily = bestFamily;
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(physical, &props);
    name = props.deviceName;
    type = props.deviceType;
    vkGetPhysicalDeviceMemoryProperties(physical, &memory);

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo qci{};
    qci.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    qci.queueFamilyIndex = queueFamily;
    qci.queueCount = 1;
    qci.pQueuePriorities = &priority;
    VkDeviceCreateInfo dci{};
    dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    dci.queueCreateInfoCount = 1;
    dci.pQueueCreateInfos = &qci;
    if (VkResult r = vkCreateDevice(physical, &dci, nullptr, &device); r != VK_SUCCESS) {
      device = VK_NULL_HANDLE;
      return vkError("vkCreateDevice on " + name, r);
    }
#define SOMM_LOAD_DEVICE(f)                                                                               \
  (f) = reinterpret_cast<PFN_##f>(vkGetDeviceProcAddr(device, #f));                                       \
  if (!f) {                                                                                               \
    auto destroy = reinterpret_cast<PFN_vkDestroyDevice>(vkGetDeviceProcAddr(device, "vkDestroyDevice")); \
    if (destroy) destroy(device, nullptr);                                                                \
    device = VK_NULL_HANDLE;                                                                              \
    return makeError(ErrorCode::UnsupportedFormat, "Vulkan: the device has no " #f);                      \
  }
    SOMM_VK_DEVICE_FNS(SOMM_LOAD_DEVICE)
#undef SOMM_LOAD_DEVICE
    vkGetDeviceQueue(device, queueFamily, 0, &queue);
    return createPipelines();
  }

  Status createPipelines() {
    VkDescriptorSetLayoutBinding bindings[3]{};
    for (uint32_t i = 0; i < 3; ++i) {
      bindings[i].binding = i;
      bindings[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      bindings[i].descriptorCount = 1;
      bindings[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
    }
    VkDescriptorSetLayoutCreateInfo lci{};
    lci.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    lci.bindingCount = 3;
    lci.pBindings = bindings;
    if (VkResult r = vkCreateDescriptorSetLayout(device, &lci, nullptr, &setLayout); r != VK_SUCCESS)
      return vkError("vkCreateDescriptorSetLayout", r);
    VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(PushConstants)};
    VkPipelineLayoutCreateInfo plci{};
    plci.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    plci.setLayoutCount = 1;
    plci.pSetLayouts = &setLayout;
    plci.pushConstantRangeCount = 1;
    plci.pPushConstantRanges = &range;
    if (VkResult r = vkCreatePipelineLayout(device, &plci, nullptr, &pipelineLayout); r != VK_SUCCESS)
      return vkError("vkCreatePipelineLayout", r);

    const struct {
      const uint32_t* code;
      size_t bytes;
    } kernels[2] = {{somm_check_glsl, sizeof(somm_check_glsl)}, {somm_check_hlsl, sizeof(somm_check_hlsl)}};
    for (int k = 0; k < 2; ++k) {
      VkShaderModuleCreateInfo smci{};
      smci.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
      smci.codeSize = kernels[k].bytes;
      smci.pCode = kernels[k].code;
      VkShaderModule module = VK_NULL_HANDLE;
      if (VkResult r = vkCreateShaderModule(device, &smci, nullptr, &module); r != VK_SUCCESS)
        return vkError("vkCreateShaderModule", r);
      VkComputePipelineCreateInfo cpci{};
      cpci.sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO;
      cpci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
      cpci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
      cpci.stage.module = module;
      cpci.stage.pName = "main";
      cpci.layout = pipelineLayout;
      const VkResult r = vkCreateComputePipelines(device, VK_NULL_HANDLE, 1, &cpci, nullptr, &pipelines[k]);
      vkDestroyShaderModule(device, module, nullptr);
      if (r != VK_SUCCESS) {
        pipelines[k] = VK_NULL_HANDLE;
        return vkError(std::string("vkCreateComputePipelines (") + (k ? "hlsl" : "glsl") + " kernel)", r);
      }
    }

    VkDescriptorPoolSize ps{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 3};
    VkDescriptorPoolCreateInfo dpci{};
    dpci.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    dpci.maxSets = 1;
    dpci.poolSizeCount = 1;
    dpci.pPoolSizes = &ps;
    if (VkResult r = vkCreateDescriptorPool(device, &dpci, nullptr, &pool); r != VK_SUCCESS)
      return vkError("vkCreateDescriptorPool", r);
    VkDescriptorSetAllocateInfo dsai{};
    dsai.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    dsai.descriptorPool = pool;
    dsai.descriptorSetCount = 1;
    dsai.pSetLayouts = &setLayout;
    if (VkResult r = vkAllocateDescriptorSets(device, &dsai, &set); r != VK_SUCCESS)
      return vkError("vkAllocateDescriptorSets", r);

    VkCommandPoolCreateInfo cpi{};
    cpi.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    cpi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    cpi.queueFamilyIndex = queueFamily;
    if (VkResult r = vkCreateCommandPool(device, &cpi, nullptr, &commandPool); r != VK_SUCCESS)
      return vkError("vkCreateCommandPool", r);
    VkCommandBufferAllocateInfo cbai{};
    cbai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    cbai.commandPool = commandPool;
    cbai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cbai.commandBufferCount = 1;
    if (VkResult r = vkAllocateCommandBuffers(device, &cbai, &commands); r != VK_SUCCESS)
      return vkError("vkAllocateCommandBuffers", r);
    VkFenceCreateInfo fci{};
    fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    if (VkResult r = vkCreateFence(device, &fci, nullptr, &fence); r != VK_SUCCESS)
      return vkError("vkCreateFence", r);
    return Ok{};
  }

  // Host-visible, coherent memory; device-local as well when the device has such a type (UMA, resizable BAR).
  Result<Buffer> createBuffer(VkDeviceSize size) {
    Buffer b;
    b.size = size;
    VkBufferCreateInfo bci{};
    bci.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    bci.size = size;
    bci.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
    bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    if (VkResult r = vkCreateBuffer(device, &bci, nullptr, &b.buffer); r != VK_SUCCESS)
      return vkError("vkCreateBuffer (" + std::to_string(size) + " bytes)", r);
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(device, b.buffer, &req);
    const VkMemoryPropertyFlags need =
        VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
    int type = -1;
    for (int pass = 0; pass < 2 && type < 0; ++pass)
      for (uint32_t i = 0; i < memory.memoryTypeCount; ++i) {
        const VkMemoryPropertyFlags f = memory.memoryTypes[i].propertyFlags;
        const VkMemoryPropertyFlags want = pass == 0 ? need | VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT : need;
        if ((req.memoryTypeBits & (1u << i)) && (f & want) == want) {
          type = int(i);
          break;
        }
      }
    if (type < 0) {
      vkDestroyBuffer(device, b.buffer, nullptr);
      return makeError(ErrorCode::UnsupportedFormat,
                       "Vulkan: " + name + " has no host-visible coherent memory");
    }
    VkMemoryAllocateInfo mai{};
    mai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    mai.allocationSize = req.size;
    mai.memoryTypeIndex = uint32_t(type);
    if (VkResult r = vkAllocateMemory(device, &mai, nullptr, &b.memory); r != VK_SUCCESS) {
      vkDestroyBuffer(device, b.buffer, nullptr);
      return vkError("vkAllocateMemory (" + std::to_string(size) + " bytes)", r);
    }
    vkBindBufferMemory(device, b.buffer, b.memory, 0);
    if (VkResult r = vkMapMemory(device, b.memory, 0, VK_WHOLE_SIZE, 0, &b.mapped); r != VK_SUCCESS) {
      destroy(b);
      return vkError("vkMapMemory", r);
    }
    return b;
  }
  void destroy(Buffer& b) {
    if (b.mapped) vkUnmapMemory(device, b.memory);
    if (b.buffer) vkDestroyBuffer(device, b.buffer, nullptr);
    if (b.memory) vkFreeMemory(device, b.memory, nullptr);
    b = Buffer{};
  }
};

Device::Device(std::unique_ptr<Impl> impl) noexcept : impl_(std::move(impl)) {}
Device::Device(Device&&) noexcept = default;
Device& Device::operator=(Device&&) noexcept = default;
Device::~Device() = default;

Result<Device> Device::open() {
  auto impl = std::make_unique<Impl>();
  if (Status s = impl->init(); !s) return s.error();
  return Device(std::move(impl));
}

const std::string& Device::name() const noexcept {
  return impl_->name;
}

const char* Device::typeName() const noexcept {
  switch (impl_->type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return "CPU";
    default:
      return "other";
  }
}

Result<std::vector<uint32_t>> Device::run(ShaderLanguage language, LookupMode mode,
                                          const std::vector<uint8_t>& buffer, uint32_t base,
                                          const std::vector<Query>& queries, uint32_t repeats,
                                          double* seconds) {
  Impl& d = *impl_;
  std::vector<uint32_t> results(queries.size());
  if (queries.empty()) {
    if (seconds) *seconds = 0;
    return results;
  }
  if (queries.size() > uint64_t(kMaxGroupsX) * kLocalSize * kMaxGroupsX || buffer.size() > 0xfffffff0u)
    return makeError(ErrorCode::LimitExceeded, "gpu: too many queries or a buffer beyond 4 GiB");
  // The shaders read up to 8 bytes after an addressed byte; round to whole words.
  const VkDeviceSize arrayBytes = (VkDeviceSize(buffer.size()) + 16 + 3) & ~VkDeviceSize(3);
  auto arrays = d.createBuffer(arrayBytes);
  if (!arrays) return arrays.error();
  auto in = d.createBuffer(queries.size() * sizeof(Query));
  if (!in) {
    d.destroy(*arrays);
    return in.error();
  }
  auto out = d.createBuffer(queries.size() * sizeof(uint32_t));
  if (!out) {
    d.destroy(*arrays);
    d.destroy(*in);
    return out.error();
  }
  std::memset(arrays->mapped, 0, size_t(arrayBytes));
  if (!buffer.empty()) std::memcpy(arrays->mapped, buffer.data(), buffer.size());
  std::memcpy(in->mapped, queries.data(), queries.size() * sizeof(Query));
  std::memset(out->mapped, 0xff, queries.size() * sizeof(uint32_t));

  VkDescriptorBufferInfo infos[3] = {
      {arrays->buffer, 0, VK_WHOLE_SIZE}, {in->buffer, 0, VK_WHOLE_SIZE}, {out->buffer, 0, VK_WHOLE_SIZE}};
  VkWriteDescriptorSet writes[3]{};
  for (uint32_t i = 0; i < 3; ++i) {
    writes[i].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    writes[i].dstSet = d.set;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &infos[i];
  }
  d.vkUpdateDescriptorSets(d.device, 3, writes, 0, nullptr);

  const uint64_t groups = (queries.size() + kLocalSize - 1) / kLocalSize;
  const uint32_t groupsX = uint32_t(std::min<uint64_t>(groups, kMaxGroupsX));
  const uint32_t groupsY = uint32_t((groups + groupsX - 1) / groupsX);
  const PushConstants pc{base, uint32_t(queries.size()), uint32_t(mode), groupsX * kLocalSize};

  VkCommandBufferBeginInfo begin{};
  begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  d.vkBeginCommandBuffer(d.commands, &begin);
  d.vkCmdBindPipeline(d.commands, VK_PIPELINE_BIND_POINT_COMPUTE, d.pipelines[int(language)]);
  d.vkCmdBindDescriptorSets(d.commands, VK_PIPELINE_BIND_POINT_COMPUTE, d.pipelineLayout, 0, 1, &d.set, 0,
                            nullptr);
  d.vkCmdPushConstants(d.commands, d.pipelineLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof pc, &pc);
  d.vkCmdDispatch(d.commands, groupsX, groupsY, 1);
  VkMemoryBarrier barrier{};
  barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  d.vkCmdPipelineBarrier(d.commands, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                         &barrier, 0, nullptr, 0, nullptr);
  d.vkEndCommandBuffer(d.commands);

  Status status = Ok{};
  double best = 0;
  for (uint32_t rep = 0; rep < std::max(repeats, 1u); ++rep) {
    VkSubmitInfo si{};
    si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    si.commandBufferCount = 1;
    si.pCommandBuffers = &d.commands;
    const auto t0 = std::chrono::steady_clock::now();
    if (VkResult r = d.vkQueueSubmit(d.queue, 1, &si, d.fence); r != VK_SUCCESS) {
      status = vkError("vkQueueSubmit", r);
      break;
    }
    const VkResult w = d.vkWaitForFences(d.device, 1, &d.fence, VK_TRUE, UINT64_MAX);
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    d.vkResetFences(d.device, 1, &d.fence);
    if (w != VK_SUCCESS) {
      status = vkError("vkWaitForFences", w);
      break;
    }
    if (rep == 0 || t < best) best = t;
  }
  if (status) std::memcpy(results.data(), out->mapped, results.size() * sizeof(uint32_t));
  d.destroy(*arrays);
  d.destroy(*in);
  d.destroy(*out);
  if (!status) return status.error();
  if (seconds) *seconds = best;
  return results;
}

}  // namespace somm::gpu
