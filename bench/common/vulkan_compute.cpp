// The Vulkan compute harness (vulkan_compute.h). Every Vulkan object is created here and destroyed
// in ~Impl in reverse order; each driver call that can fail is checked with VK_TRY.
#include "vulkan_compute.h"

#include <unistd.h>
#include <vulkan/vulkan.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace drtv::testing {
namespace {

constexpr const char* kNoDeviceHint =
    " (no Vulkan driver found: without a GPU, install Mesa's CPU driver lavapipe, which scripts/bootstrap "
    "does: mesa-vulkan-drivers)";

std::string resultName(VkResult r) {
  switch (r) {
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_FORMAT_NOT_SUPPORTED: return "VK_ERROR_FORMAT_NOT_SUPPORTED";
    case VK_ERROR_INVALID_SHADER_NV: return "VK_ERROR_INVALID_SHADER_NV";
    default: return "VkResult " + std::to_string(int(r));
  }
}

#define VK_TRY(call)                                                            \
  do {                                                                          \
    if (const VkResult vk_try_r_ = (call); vk_try_r_ != VK_SUCCESS)             \
      return fail(std::string("vulkan: ") + #call + ": " + resultName(vk_try_r_)); \
  } while (0)

// A zeroed Vulkan create-info struct with its sType set (a braced {sType} would leave -Wextra
// warning about every other member).
template <class T>
T vkStruct(VkStructureType type) {
  T s{};
  s.sType = type;
  return s;
}

VkDescriptorType descriptorType(BindingKind k) {
  switch (k) {
    case BindingKind::kTextureAndSampler: return VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    case BindingKind::kTexture: return VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE;
    case BindingKind::kSampler: return VK_DESCRIPTOR_TYPE_SAMPLER;
    case BindingKind::kUniformBuffer: return VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    case BindingKind::kStorageBuffer: return VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  }
  return VK_DESCRIPTOR_TYPE_MAX_ENUM;
}

}  // namespace

struct VulkanCompute::Impl {
  struct Texture {
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
  };
  struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    std::byte* mapped = nullptr;
    size_t bytes = 0;
  };
  struct Pipeline {
    VkShaderModule module = VK_NULL_HANDLE;
    VkDescriptorSetLayout set_layout = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkPipeline pipeline = VK_NULL_HANDLE;
    VkDescriptorSet set = VK_NULL_HANDLE;  // freed with the pool
  };

  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  VkPhysicalDeviceMemoryProperties memory_properties{};
  VkDevice device = VK_NULL_HANDLE;
  uint32_t queue_family = 0;
  bool timestamps = false;
  double timestamp_period_ns = 1.0;
  VkQueue queue = VK_NULL_HANDLE;
  VkCommandPool command_pool = VK_NULL_HANDLE;
  VkDescriptorPool descriptor_pool = VK_NULL_HANDLE;
  VkQueryPool query_pool = VK_NULL_HANDLE;
  VkSampler sampler = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  std::vector<Texture> textures;
  std::vector<Buffer> buffers;
  std::vector<Pipeline> pipelines;

  ~Impl() {
    if (device) {
      vkDeviceWaitIdle(device);
      for (Pipeline& p : pipelines) {
        vkDestroyPipeline(device, p.pipeline, nullptr);
        vkDestroyPipelineLayout(device, p.layout, nullptr);
        vkDestroyDescriptorSetLayout(device, p.set_layout, nullptr);
        vkDestroyShaderModule(device, p.module, nullptr);
      }
      for (Buffer& b : buffers) {
        vkDestroyBuffer(device, b.buffer, nullptr);
        vkFreeMemory(device, b.memory, nullptr);  // unmaps
      }
      for (Texture& t : textures) {
        vkDestroyImageView(device, t.view, nullptr);
        vkDestroyImage(device, t.image, nullptr);
        vkFreeMemory(device, t.memory, nullptr);
      }
      vkDestroyFence(device, fence, nullptr);
      vkDestroySampler(device, sampler, nullptr);
      vkDestroyQueryPool(device, query_pool, nullptr);
      vkDestroyDescriptorPool(device, descriptor_pool, nullptr);
      vkDestroyCommandPool(device, command_pool, nullptr);
      vkDestroyDevice(device, nullptr);
    }
    if (instance) vkDestroyInstance(instance, nullptr);
  }

  // A memory type allowed by `type_bits` with all of `flags`, else (device-local asked for, a
  // device without it) one with none required.
  Result<uint32_t> memoryType(uint32_t type_bits, VkMemoryPropertyFlags flags) const {
    for (VkMemoryPropertyFlags want : {flags, VkMemoryPropertyFlags(0)})
      for (uint32_t i = 0; i < memory_properties.memoryTypeCount; ++i)
        if ((type_bits & (1u << i)) && (memory_properties.memoryTypes[i].propertyFlags & want) == want) return i;
    return fail("vulkan: no memory type for bits " + std::to_string(type_bits));
  }

  // A buffer with its own memory: host-visible, coherent and mapped (zeroed), or device-local.
  Result<Buffer> makeBuffer(size_t bytes, VkBufferUsageFlags usage, bool host_visible = true) const {
    Buffer b;
    b.bytes = bytes;
    auto info = vkStruct<VkBufferCreateInfo>(VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
    info.size = bytes;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    VK_TRY(vkCreateBuffer(device, &info, nullptr, &b.buffer));
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(device, b.buffer, &req);
    // Coherent: the host writes and reads through the mapping without flushes.
    auto type = memoryType(req.memoryTypeBits, host_visible ? VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT
                                                            : VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (!type) {
      vkDestroyBuffer(device, b.buffer, nullptr);
      return std::unexpected(type.error());
    }
    auto alloc = vkStruct<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = *type;
    auto cleanup = [&](VkResult r) {
      vkDestroyBuffer(device, b.buffer, nullptr);
      if (b.memory) vkFreeMemory(device, b.memory, nullptr);
      return fail("vulkan: buffer of " + std::to_string(bytes) + " bytes: " + resultName(r));
    };
    if (VkResult r = vkAllocateMemory(device, &alloc, nullptr, &b.memory); r != VK_SUCCESS) return cleanup(r);
    if (VkResult r = vkBindBufferMemory(device, b.buffer, b.memory, 0); r != VK_SUCCESS) return cleanup(r);
    if (!host_visible) return b;
    void* p = nullptr;
    if (VkResult r = vkMapMemory(device, b.memory, 0, VK_WHOLE_SIZE, 0, &p); r != VK_SUCCESS) return cleanup(r);
    b.mapped = static_cast<std::byte*>(p);
    std::memset(b.mapped, 0, bytes);
    return b;
  }

  // Records commands with `record` into a fresh primary command buffer, submits it and waits.
  template <class F>
  Result<void> submitAndWait(F&& record) {
    auto alloc = vkStruct<VkCommandBufferAllocateInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
    alloc.commandPool = command_pool;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    VK_TRY(vkAllocateCommandBuffers(device, &alloc, &cmd));
    auto begin = vkStruct<VkCommandBufferBeginInfo>(VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VkResult r = vkBeginCommandBuffer(cmd, &begin);
    if (r == VK_SUCCESS) {
      record(cmd);
      r = vkEndCommandBuffer(cmd);
    }
    if (r == VK_SUCCESS) r = vkResetFences(device, 1, &fence);
    if (r == VK_SUCCESS) {
      auto submit = vkStruct<VkSubmitInfo>(VK_STRUCTURE_TYPE_SUBMIT_INFO);
      submit.commandBufferCount = 1;
      submit.pCommandBuffers = &cmd;
      r = vkQueueSubmit(queue, 1, &submit, fence);
    }
    if (r == VK_SUCCESS) r = vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX);
    vkFreeCommandBuffers(device, command_pool, 1, &cmd);
    if (r != VK_SUCCESS) return fail("vulkan: submit: " + resultName(r));
    return {};
  }
};

VulkanCompute::VulkanCompute(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
VulkanCompute::~VulkanCompute() = default;

Result<std::unique_ptr<VulkanCompute>> VulkanCompute::create() {
  auto impl = std::make_unique<Impl>();
  auto app = vkStruct<VkApplicationInfo>(VK_STRUCTURE_TYPE_APPLICATION_INFO);
  app.pApplicationName = "drtv shader tests";
  app.apiVersion = VK_API_VERSION_1_1;
  auto instance_info = vkStruct<VkInstanceCreateInfo>(VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
  instance_info.pApplicationInfo = &app;
  if (const VkResult r = vkCreateInstance(&instance_info, nullptr, &impl->instance); r != VK_SUCCESS)
    return fail("vulkan: vkCreateInstance: " + resultName(r) + (r == VK_ERROR_INCOMPATIBLE_DRIVER ? kNoDeviceHint : ""));

  uint32_t count = 0;
  VK_TRY(vkEnumeratePhysicalDevices(impl->instance, &count, nullptr));
  std::vector<VkPhysicalDevice> devices(count);
  VK_TRY(vkEnumeratePhysicalDevices(impl->instance, &count, devices.data()));
  if (count == 0) return fail(std::string("vulkan: the loader found no device") + kNoDeviceHint);

  // The best device that has a compute queue: discrete GPU, integrated GPU, anything else.
  auto rank = [](VkPhysicalDeviceType t) {
    return t == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU ? 0 : t == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU ? 1 : 2;
  };
  int best_rank = 3;
  VkPhysicalDeviceProperties best_props{};
  for (VkPhysicalDevice d : devices) {
    uint32_t families = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(d, &families, nullptr);
    std::vector<VkQueueFamilyProperties> props(families);
    vkGetPhysicalDeviceQueueFamilyProperties(d, &families, props.data());
    for (uint32_t f = 0; f < families; ++f) {
      if (!(props[f].queueFlags & VK_QUEUE_COMPUTE_BIT)) continue;
      VkPhysicalDeviceProperties p;
      vkGetPhysicalDeviceProperties(d, &p);
      if (rank(p.deviceType) < best_rank) {
        best_rank = rank(p.deviceType);
        best_props = p;
        impl->physical = d;
        impl->queue_family = f;
        impl->timestamps = props[f].timestampValidBits > 0 && p.limits.timestampPeriod > 0.f;
        impl->timestamp_period_ns = p.limits.timestampPeriod;
      }
      break;
    }
  }
  if (!impl->physical) return fail("vulkan: " + std::to_string(count) + " device(s), none with a compute queue");
  vkGetPhysicalDeviceMemoryProperties(impl->physical, &impl->memory_properties);

  const float priority = 1.f;
  auto queue_info = vkStruct<VkDeviceQueueCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
  queue_info.queueFamilyIndex = impl->queue_family;
  queue_info.queueCount = 1;
  queue_info.pQueuePriorities = &priority;
  auto device_info = vkStruct<VkDeviceCreateInfo>(VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO);
  device_info.queueCreateInfoCount = 1;
  device_info.pQueueCreateInfos = &queue_info;
  VK_TRY(vkCreateDevice(impl->physical, &device_info, nullptr, &impl->device));
  vkGetDeviceQueue(impl->device, impl->queue_family, 0, &impl->queue);

  auto pool_info = vkStruct<VkCommandPoolCreateInfo>(VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
  pool_info.queueFamilyIndex = impl->queue_family;
  VK_TRY(vkCreateCommandPool(impl->device, &pool_info, nullptr, &impl->command_pool));

  // Enough for a few ambient pipelines (each: 3 textures, a sampler, a uniform and 2 storage).
  const VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 32}, {VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, 32},
                                        {VK_DESCRIPTOR_TYPE_SAMPLER, 8}, {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 8},
                                        {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 16}};
  auto dp = vkStruct<VkDescriptorPoolCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
  dp.maxSets = 8;
  dp.poolSizeCount = uint32_t(std::size(sizes));
  dp.pPoolSizes = sizes;
  VK_TRY(vkCreateDescriptorPool(impl->device, &dp, nullptr, &impl->descriptor_pool));

  if (impl->timestamps) {
    auto q = vkStruct<VkQueryPoolCreateInfo>(VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO);
    q.queryType = VK_QUERY_TYPE_TIMESTAMP;
    q.queryCount = 2;
    VK_TRY(vkCreateQueryPool(impl->device, &q, nullptr, &impl->query_pool));
  }

  // The talk's sampler: trilinear within the level, clamp addressing (the frac trick and the
  // duplicated boundary make clamp correct across the wrap), one level.
  auto s = vkStruct<VkSamplerCreateInfo>(VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO);
  s.magFilter = s.minFilter = VK_FILTER_LINEAR;
  s.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  s.addressModeU = s.addressModeV = s.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  s.maxLod = 0.f;
  VK_TRY(vkCreateSampler(impl->device, &s, nullptr, &impl->sampler));

  auto f = vkStruct<VkFenceCreateInfo>(VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
  VK_TRY(vkCreateFence(impl->device, &f, nullptr, &impl->fence));

  std::unique_ptr<VulkanCompute> out(new VulkanCompute(std::move(impl)));
  const bool cpu = best_props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
  out->is_cpu_ = cpu;
  out->sub_texel_bits_ = best_props.limits.subTexelPrecisionBits;
  std::ostringstream d;
  d << best_props.deviceName << " [" << (cpu ? "cpu" : best_rank == 0 ? "discrete gpu" : best_rank == 1 ? "integrated gpu" : "other")
    << ", Vulkan " << VK_API_VERSION_MAJOR(best_props.apiVersion) << '.' << VK_API_VERSION_MINOR(best_props.apiVersion) << ']';
  out->description_ = d.str();
  return out;
}

Result<int> VulkanCompute::addTexture3D(glm::ivec3 size, std::span<const uint32_t> texels) {
  Impl& m = *impl_;
  const size_t count = size_t(size.x) * size.y * size.z;
  if (size.x < 1 || size.y < 1 || size.z < 1 || texels.size() != count)
    return fail("vulkan: texture of " + std::to_string(texels.size()) + " texels does not match its size");
  Impl::Texture t;
  auto info = vkStruct<VkImageCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
  info.imageType = VK_IMAGE_TYPE_3D;
  info.format = VK_FORMAT_R8G8B8A8_UNORM;
  info.extent = {uint32_t(size.x), uint32_t(size.y), uint32_t(size.z)};
  info.mipLevels = 1;
  info.arrayLayers = 1;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VK_TRY(vkCreateImage(m.device, &info, nullptr, &t.image));
  m.textures.push_back(t);  // owned from here on, destroyed with the harness
  Impl::Texture& tex = m.textures.back();
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(m.device, tex.image, &req);
  auto type = m.memoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  if (!type) return std::unexpected(type.error());
  auto alloc = vkStruct<VkMemoryAllocateInfo>(VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO);
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = *type;
  VK_TRY(vkAllocateMemory(m.device, &alloc, nullptr, &tex.memory));
  VK_TRY(vkBindImageMemory(m.device, tex.image, tex.memory, 0));

  auto view = vkStruct<VkImageViewCreateInfo>(VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
  view.image = tex.image;
  view.viewType = VK_IMAGE_VIEW_TYPE_3D;
  view.format = info.format;
  view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  VK_TRY(vkCreateImageView(m.device, &view, nullptr, &tex.view));

  // Through a staging buffer: optimal tiling is opaque to the host.
  auto staging = m.makeBuffer(count * sizeof(uint32_t), VK_BUFFER_USAGE_TRANSFER_SRC_BIT);
  if (!staging) return std::unexpected(staging.error());
  std::memcpy(staging->mapped, texels.data(), count * sizeof(uint32_t));
  const VkImage image = tex.image;
  auto done = m.submitAndWait([&](VkCommandBuffer cmd) {
    auto b = vkStruct<VkImageMemoryBarrier>(VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER);
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image;
    b.subresourceRange = view.subresourceRange;
    b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    b.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    b.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr, 1, &b);
    VkBufferImageCopy copy{};
    copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    copy.imageExtent = info.extent;
    vkCmdCopyBufferToImage(cmd, staging->buffer, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
    b.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    b.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    b.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    b.dstAccessMask = VK_ACCESS_SHADER_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 0, nullptr, 0, nullptr, 1, &b);
  });
  vkDestroyBuffer(m.device, staging->buffer, nullptr);
  vkFreeMemory(m.device, staging->memory, nullptr);
  if (!done) return std::unexpected(done.error());
  return int(m.textures.size()) - 1;
}

Result<int> VulkanCompute::addBuffer(size_t bytes, BufferKind kind) {
  const VkBufferUsageFlags transfer = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  auto b = kind == BufferKind::kUniform   ? impl_->makeBuffer(bytes, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT)
           : kind == BufferKind::kStaging ? impl_->makeBuffer(bytes, transfer)
                                          : impl_->makeBuffer(bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | transfer, false);
  if (!b) return std::unexpected(b.error());
  impl_->buffers.push_back(*b);
  return int(impl_->buffers.size()) - 1;
}

Result<void> VulkanCompute::copyBuffer(int src, int dst, size_t bytes) {
  Impl& m = *impl_;
  const Impl::Buffer &from = m.buffers.at(size_t(src)), &to = m.buffers.at(size_t(dst));
  if (bytes > from.bytes || bytes > to.bytes) return fail("vulkan: copy of " + std::to_string(bytes) + " bytes overruns a buffer");
  if (bytes == 0) return {};
  return m.submitAndWait([&](VkCommandBuffer cmd) {
    const VkBufferCopy region{0, 0, bytes};
    vkCmdCopyBuffer(cmd, from.buffer, to.buffer, 1, &region);
    // Visible to later shader reads and to host reads of the destination (the fence orders
    // submissions; the barrier makes the writes available).
    auto b = vkStruct<VkMemoryBarrier>(VK_STRUCTURE_TYPE_MEMORY_BARRIER);
    b.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    b.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                         &b, 0, nullptr, 0, nullptr);
  });
}

std::span<std::byte> VulkanCompute::bufferMemory(int buffer) const {
  const Impl::Buffer& b = impl_->buffers.at(size_t(buffer));
  if (!b.mapped) return {};  // device-local
  return {b.mapped, b.bytes};
}

Result<int> VulkanCompute::addPipeline(std::span<const uint32_t> spirv, const std::string& entry,
                                       const std::vector<PipelineBinding>& bindings) {
  Impl& m = *impl_;
  for (const PipelineBinding& b : bindings) {
    const bool texture = b.kind == BindingKind::kTexture || b.kind == BindingKind::kTextureAndSampler;
    const bool buffer = b.kind == BindingKind::kUniformBuffer || b.kind == BindingKind::kStorageBuffer;
    if ((texture && (b.resource < 0 || size_t(b.resource) >= m.textures.size())) ||
        (buffer && (b.resource < 0 || size_t(b.resource) >= m.buffers.size())))
      return fail("vulkan: binding " + std::to_string(b.binding) + " names no resource");
  }
  m.pipelines.emplace_back();
  Impl::Pipeline& p = m.pipelines.back();

  auto module = vkStruct<VkShaderModuleCreateInfo>(VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
  module.codeSize = spirv.size_bytes();
  module.pCode = spirv.data();
  VK_TRY(vkCreateShaderModule(m.device, &module, nullptr, &p.module));

  std::vector<VkDescriptorSetLayoutBinding> layout_bindings;
  for (const PipelineBinding& b : bindings)
    layout_bindings.push_back({b.binding, descriptorType(b.kind), 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
  auto set_info = vkStruct<VkDescriptorSetLayoutCreateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
  set_info.bindingCount = uint32_t(layout_bindings.size());
  set_info.pBindings = layout_bindings.data();
  VK_TRY(vkCreateDescriptorSetLayout(m.device, &set_info, nullptr, &p.set_layout));
  auto layout_info = vkStruct<VkPipelineLayoutCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
  layout_info.setLayoutCount = 1;
  layout_info.pSetLayouts = &p.set_layout;
  VK_TRY(vkCreatePipelineLayout(m.device, &layout_info, nullptr, &p.layout));

  auto pipeline_info = vkStruct<VkComputePipelineCreateInfo>(VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
  pipeline_info.stage = vkStruct<VkPipelineShaderStageCreateInfo>(VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO);
  pipeline_info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  pipeline_info.stage.module = p.module;
  pipeline_info.stage.pName = entry.c_str();
  pipeline_info.layout = p.layout;
  VK_TRY(vkCreateComputePipelines(m.device, VK_NULL_HANDLE, 1, &pipeline_info, nullptr, &p.pipeline));

  auto alloc = vkStruct<VkDescriptorSetAllocateInfo>(VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
  alloc.descriptorPool = m.descriptor_pool;
  alloc.descriptorSetCount = 1;
  alloc.pSetLayouts = &p.set_layout;
  VK_TRY(vkAllocateDescriptorSets(m.device, &alloc, &p.set));

  // Descriptor infos must stay put until vkUpdateDescriptorSets: sized up front.
  std::vector<VkDescriptorImageInfo> images(bindings.size());
  std::vector<VkDescriptorBufferInfo> buffers(bindings.size());
  std::vector<VkWriteDescriptorSet> writes;
  for (size_t i = 0; i < bindings.size(); ++i) {
    const PipelineBinding& b = bindings[i];
    auto w = vkStruct<VkWriteDescriptorSet>(VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
    w.dstSet = p.set;
    w.dstBinding = b.binding;
    w.descriptorCount = 1;
    w.descriptorType = descriptorType(b.kind);
    switch (b.kind) {
      case BindingKind::kTextureAndSampler:
      case BindingKind::kTexture:
        images[i] = {b.kind == BindingKind::kTextureAndSampler ? m.sampler : VK_NULL_HANDLE, m.textures[b.resource].view,
                     VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        w.pImageInfo = &images[i];
        break;
      case BindingKind::kSampler:
        images[i] = {m.sampler, VK_NULL_HANDLE, VK_IMAGE_LAYOUT_UNDEFINED};
        w.pImageInfo = &images[i];
        break;
      case BindingKind::kUniformBuffer:
      case BindingKind::kStorageBuffer:
        buffers[i] = {m.buffers[b.resource].buffer, 0, VK_WHOLE_SIZE};
        w.pBufferInfo = &buffers[i];
        break;
    }
    writes.push_back(w);
  }
  vkUpdateDescriptorSets(m.device, uint32_t(writes.size()), writes.data(), 0, nullptr);
  return int(m.pipelines.size()) - 1;
}

Result<double> VulkanCompute::dispatch(int pipeline, uint32_t groups_x) {
  Impl& m = *impl_;
  const Impl::Pipeline& p = m.pipelines.at(size_t(pipeline));
  const auto start = std::chrono::steady_clock::now();
  auto done = m.submitAndWait([&](VkCommandBuffer cmd) {
    if (m.timestamps) {
      vkCmdResetQueryPool(cmd, m.query_pool, 0, 2);
      vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, m.query_pool, 0);
    }
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 1, &p.set, 0, nullptr);
    vkCmdDispatch(cmd, groups_x, 1, 1);
    if (m.timestamps) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, m.query_pool, 1);
    // The shader's writes made available to a later copy or to the host's reads.
    auto b = vkStruct<VkMemoryBarrier>(VK_STRUCTURE_TYPE_MEMORY_BARRIER);
    b.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    b.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                         &b, 0, nullptr, 0, nullptr);
  });
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!done) return std::unexpected(done.error());
  if (!m.timestamps) return wall_s;
  uint64_t ticks[2] = {0, 0};
  VK_TRY(vkGetQueryPoolResults(m.device, m.query_pool, 0, 2, sizeof(ticks), ticks, sizeof(uint64_t),
                               VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
  return double(ticks[1] - ticks[0]) * m.timestamp_period_ns * 1e-9;
}

Result<std::vector<uint32_t>> compileWithGlslang(const std::string& arguments) {
  static int counter = 0;
  const std::filesystem::path base = std::filesystem::temp_directory_path() /
                                     ("drtv_glslang_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  const std::filesystem::path spv = base.string() + ".spv", log = base.string() + ".log";
  const std::string command = "glslangValidator " + arguments + " -o " + spv.string() + " > " + log.string() + " 2>&1";
  const int rc = std::system(command.c_str());
  std::ifstream log_file(log);
  std::stringstream messages;
  messages << log_file.rdbuf();
  std::error_code ignored;
  std::filesystem::remove(log, ignored);
  if (rc != 0) {
    std::filesystem::remove(spv, ignored);
    return fail("glslangValidator " + arguments + ": exit " + std::to_string(rc) + ":\n" + messages.str());
  }
  std::ifstream f(spv, std::ios::binary);
  std::vector<char> bytes{std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
  std::filesystem::remove(spv, ignored);
  if (bytes.empty() || bytes.size() % 4 != 0) return fail("glslangValidator " + arguments + ": no SPIR-V written");
  std::vector<uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), bytes.size());
  return words;
}

}  // namespace drtv::testing
