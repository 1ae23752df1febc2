/* vk_context.c: headless Vulkan 1.2 instance, device choice, queue and command pool. */
#include "renderer/vk/vk_context.h"

#include <ctype.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#define VALIDATION_LAYER "VK_LAYER_KHRONOS_validation"

/* ---- results ----------------------------------------------------------------------------- */

const char *rd_vk_strerror(rd_vk_result r)
{
    switch (r) {
    case RD_VK_OK:
        return "ok";
    case RD_VK_ERR_NO_LOADER:
        return "no usable Vulkan loader";
    case RD_VK_ERR_NO_VALIDATION:
        return "validation layer not available";
    case RD_VK_ERR_NO_DEVICE:
        return "no Vulkan device";
    case RD_VK_ERR_DEVICE_NOT_FOUND:
        return "no device matches the selector";
    case RD_VK_ERR_UNSUPPORTED:
        return "device lacks a required feature";
    case RD_VK_ERR_OUT_OF_MEMORY:
        return "out of memory";
    case RD_VK_ERR_DEVICE_LOST:
        return "device lost";
    case RD_VK_ERR_VULKAN:
        return "Vulkan error";
    }
    return "unknown error";
}

const char *rd_vk_result_name(VkResult r)
{
    switch (r) {
#define NAME(x)                                                                                    \
    case x:                                                                                        \
        return #x;
        NAME(VK_SUCCESS)
        NAME(VK_NOT_READY)
        NAME(VK_TIMEOUT)
        NAME(VK_EVENT_SET)
        NAME(VK_EVENT_RESET)
        NAME(VK_INCOMPLETE)
        NAME(VK_ERROR_OUT_OF_HOST_MEMORY)
        NAME(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        NAME(VK_ERROR_INITIALIZATION_FAILED)
        NAME(VK_ERROR_DEVICE_LOST)
        NAME(VK_ERROR_MEMORY_MAP_FAILED)
        NAME(VK_ERROR_LAYER_NOT_PRESENT)
        NAME(VK_ERROR_EXTENSION_NOT_PRESENT)
        NAME(VK_ERROR_FEATURE_NOT_PRESENT)
        NAME(VK_ERROR_INCOMPATIBLE_DRIVER)
        NAME(VK_ERROR_TOO_MANY_OBJECTS)
        NAME(VK_ERROR_FORMAT_NOT_SUPPORTED)
        NAME(VK_ERROR_FRAGMENTED_POOL)
        NAME(VK_ERROR_UNKNOWN)
        NAME(VK_ERROR_OUT_OF_POOL_MEMORY)
        NAME(VK_ERROR_INVALID_EXTERNAL_HANDLE)
        NAME(VK_ERROR_FRAGMENTATION)
        NAME(VK_ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS)
        NAME(VK_PIPELINE_COMPILE_REQUIRED)
        NAME(VK_ERROR_SURFACE_LOST_KHR)
        NAME(VK_ERROR_NATIVE_WINDOW_IN_USE_KHR)
        NAME(VK_SUBOPTIMAL_KHR)
        NAME(VK_ERROR_OUT_OF_DATE_KHR)
        NAME(VK_ERROR_INCOMPATIBLE_DISPLAY_KHR)
        NAME(VK_ERROR_VALIDATION_FAILED_EXT)
        NAME(VK_ERROR_INVALID_SHADER_NV)
        NAME(VK_THREAD_IDLE_KHR)
        NAME(VK_THREAD_DONE_KHR)
        NAME(VK_OPERATION_DEFERRED_KHR)
        NAME(VK_OPERATION_NOT_DEFERRED_KHR)
#undef NAME
    default:
        break;
    }
    static _Thread_local char buf[40];
    snprintf(buf, sizeof buf, "VkResult(%d)", (int)r);
    return buf;
}

rd_vk_result rd_vk_from_vkresult(VkResult r)
{
    switch (r) {
    case VK_SUCCESS:
        return RD_VK_OK;
    case VK_ERROR_OUT_OF_HOST_MEMORY:
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
    case VK_ERROR_OUT_OF_POOL_MEMORY:
    case VK_ERROR_TOO_MANY_OBJECTS:
        return RD_VK_ERR_OUT_OF_MEMORY;
    case VK_ERROR_DEVICE_LOST:
        return RD_VK_ERR_DEVICE_LOST;
    case VK_ERROR_FEATURE_NOT_PRESENT:
    case VK_ERROR_EXTENSION_NOT_PRESENT:
        return RD_VK_ERR_UNSUPPORTED;
    default:
        return RD_VK_ERR_VULKAN;
    }
}

void rd_vk_errorf(char *err, size_t errlen, const char *fmt, ...)
{
    if (!err || errlen == 0) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, errlen, fmt, ap);
    va_end(ap);
}

rd_vk_result rd_vk_fail(rd_vk *vk, VkResult r, const char *what, char *err, size_t errlen)
{
    fprintf(stderr, "vulkan: %s failed: %s\n", what, rd_vk_result_name(r));
    rd_vk_errorf(err, errlen, "%s failed with %s.", what, rd_vk_result_name(r));
    if (r == VK_ERROR_DEVICE_LOST && vk) vk->device_lost = true;
    return rd_vk_from_vkresult(r);
}

/* ---- validation messenger ----------------------------------------------------------------- */

static VKAPI_ATTR VkBool32 VKAPI_CALL debug_callback(
    VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT types,
    const VkDebugUtilsMessengerCallbackDataEXT *data, void *user)
{
    (void)types;
    if (severity & (VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                    VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT)) {
        atomic_fetch_add((atomic_uint *)user, 1u);
        fprintf(stderr, "validation: %s: %s\n",
                (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) ? "error" : "warning",
                data && data->pMessage ? data->pMessage : "(no message)");
    }
    return VK_FALSE;
}

static VkDebugUtilsMessengerCreateInfoEXT messenger_info(rd_vk *vk)
{
    return (VkDebugUtilsMessengerCreateInfoEXT){
        .sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT,
        .messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                           VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT,
        .messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                       VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                       VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT,
        .pfnUserCallback = debug_callback,
        .pUserData = &vk->validation_messages,
    };
}

static bool has_layer(const char *name)
{
    uint32_t n = 0;
    if (vkEnumerateInstanceLayerProperties(&n, NULL) != VK_SUCCESS || n == 0) return false;
    VkLayerProperties *props = calloc(n, sizeof *props);
    if (!props) abort();
    bool found = false;
    if (vkEnumerateInstanceLayerProperties(&n, props) == VK_SUCCESS) {
        for (uint32_t i = 0; i < n && !found; i++)
            found = strcmp(props[i].layerName, name) == 0;
    }
    free(props);
    return found;
}

static bool has_instance_extension(const char *layer, const char *name)
{
    uint32_t n = 0;
    if (vkEnumerateInstanceExtensionProperties(layer, &n, NULL) != VK_SUCCESS || n == 0)
        return false;
    VkExtensionProperties *props = calloc(n, sizeof *props);
    if (!props) abort();
    bool found = false;
    if (vkEnumerateInstanceExtensionProperties(layer, &n, props) == VK_SUCCESS) {
        for (uint32_t i = 0; i < n && !found; i++)
            found = strcmp(props[i].extensionName, name) == 0;
    }
    free(props);
    return found;
}

/* ---- instance ----------------------------------------------------------------------------- */

static rd_vk_result create_instance(rd_vk *vk, bool validation, char *err, size_t errlen)
{
    uint32_t version = VK_API_VERSION_1_0;
    if (vkEnumerateInstanceVersion(&version) != VK_SUCCESS || version < VK_API_VERSION_1_2) {
        rd_vk_errorf(err, errlen, "The Vulkan loader supports only version %u.%u; 1.2 is required.",
                     VK_API_VERSION_MAJOR(version), VK_API_VERSION_MINOR(version));
        return RD_VK_ERR_NO_LOADER;
    }
    const char *layers[1] = {VALIDATION_LAYER};
    const char *extensions[1] = {VK_EXT_DEBUG_UTILS_EXTENSION_NAME};
    if (validation) {
        if (!has_layer(VALIDATION_LAYER)) {
            rd_vk_errorf(err, errlen, "Validation was requested but the layer %s is not installed.",
                         VALIDATION_LAYER);
            return RD_VK_ERR_NO_VALIDATION;
        }
        if (!has_instance_extension(NULL, VK_EXT_DEBUG_UTILS_EXTENSION_NAME) &&
            !has_instance_extension(VALIDATION_LAYER, VK_EXT_DEBUG_UTILS_EXTENSION_NAME)) {
            rd_vk_errorf(err, errlen, "Validation was requested but %s is not available.",
                         VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
            return RD_VK_ERR_NO_VALIDATION;
        }
    }
    VkApplicationInfo app = {
        .sType = VK_STRUCTURE_TYPE_APPLICATION_INFO,
        .pApplicationName = "probecast",
        .applicationVersion = VK_MAKE_API_VERSION(0, 0, 1, 0),
        .pEngineName = "probecast",
        .engineVersion = VK_MAKE_API_VERSION(0, 0, 1, 0),
        .apiVersion = VK_API_VERSION_1_2,
    };
    /* Chained so that instance creation and destruction are validated too. */
    VkDebugUtilsMessengerCreateInfoEXT dbg = messenger_info(vk);
    VkInstanceCreateInfo ici = {
        .sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO,
        .pNext = validation ? &dbg : NULL,
        .pApplicationInfo = &app,
        .enabledLayerCount = validation ? 1u : 0u,
        .ppEnabledLayerNames = validation ? layers : NULL,
        .enabledExtensionCount = validation ? 1u : 0u,
        .ppEnabledExtensionNames = validation ? extensions : NULL,
    };
    VkResult r = vkCreateInstance(&ici, NULL, &vk->instance);
    if (r != VK_SUCCESS) {
        vk->instance = VK_NULL_HANDLE;
        rd_vk_result code = rd_vk_fail(vk, r, "vkCreateInstance", err, errlen);
        if (r == VK_ERROR_INCOMPATIBLE_DRIVER || r == VK_ERROR_INITIALIZATION_FAILED)
            code = RD_VK_ERR_NO_LOADER;
        if (r == VK_ERROR_LAYER_NOT_PRESENT) code = RD_VK_ERR_NO_VALIDATION;
        return code;
    }
    if (validation) {
        PFN_vkCreateDebugUtilsMessengerEXT create_messenger =
            (PFN_vkCreateDebugUtilsMessengerEXT)vkGetInstanceProcAddr(
                vk->instance, "vkCreateDebugUtilsMessengerEXT");
        if (!create_messenger) {
            rd_vk_errorf(err, errlen, "vkCreateDebugUtilsMessengerEXT is not available.");
            return RD_VK_ERR_NO_VALIDATION;
        }
        r = create_messenger(vk->instance, &dbg, NULL, &vk->messenger);
        if (r != VK_SUCCESS) {
            vk->messenger = VK_NULL_HANDLE;
            return rd_vk_fail(vk, r, "vkCreateDebugUtilsMessengerEXT", err, errlen);
        }
        vk->validation = true;
    }
    return RD_VK_OK;
}

/* ---- physical device choice -------------------------------------------------------------- */

static const char *type_name(VkPhysicalDeviceType t)
{
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
        return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
        return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
        return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
        return "cpu";
    default:
        return "other";
    }
}

static int type_rank(VkPhysicalDeviceType t)
{
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
        return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
        return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
        return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
        return 1;
    default:
        return 0;
    }
}

static bool contains_nocase(const char *hay, const char *needle)
{
    size_t n = strlen(needle);
    if (n == 0) return true;
    for (; *hay; hay++) {
        size_t i = 0;
        while (i < n && hay[i] &&
               tolower((unsigned char)hay[i]) == tolower((unsigned char)needle[i]))
            i++;
        if (i == n) return true;
    }
    return false;
}

static bool is_decimal(const char *s)
{
    if (!*s) return false;
    for (; *s; s++)
        if (!isdigit((unsigned char)*s)) return false;
    return true;
}

/* Enumerates physical devices into a malloc'd array (*count may be 0 with *out NULL). */
static rd_vk_result enumerate_devices(rd_vk *vk, VkInstance instance, VkPhysicalDevice **out,
                                      uint32_t *count, char *err, size_t errlen)
{
    *out = NULL;
    *count = 0;
    uint32_t n = 0;
    VkResult r = vkEnumeratePhysicalDevices(instance, &n, NULL);
    if (r != VK_SUCCESS) return rd_vk_fail(vk, r, "vkEnumeratePhysicalDevices", err, errlen);
    if (n == 0) return RD_VK_OK;
    VkPhysicalDevice *devs = calloc(n, sizeof *devs);
    if (!devs) abort();
    r = vkEnumeratePhysicalDevices(instance, &n, devs);
    if (r != VK_SUCCESS && r != VK_INCOMPLETE) {
        free(devs);
        return rd_vk_fail(vk, r, "vkEnumeratePhysicalDevices", err, errlen);
    }
    *out = devs;
    *count = n;
    return RD_VK_OK;
}

static rd_vk_result pick_device(rd_vk *vk, const char *selector, char *err, size_t errlen)
{
    VkPhysicalDevice *devs;
    uint32_t n;
    rd_vk_result rc = enumerate_devices(vk, vk->instance, &devs, &n, err, errlen);
    if (rc != RD_VK_OK) return rc;
    if (n == 0) {
        rd_vk_errorf(err, errlen, "The Vulkan loader reports no physical device.");
        return RD_VK_ERR_NO_DEVICE;
    }
    int chosen = -1;
    if (selector && is_decimal(selector)) {
        unsigned long idx = strtoul(selector, NULL, 10);
        if (idx < n) chosen = (int)idx;
    } else if (selector) {
        for (uint32_t i = 0; i < n && chosen < 0; i++) {
            VkPhysicalDeviceProperties p;
            vkGetPhysicalDeviceProperties(devs[i], &p);
            if (contains_nocase(p.deviceName, selector)) chosen = (int)i;
        }
    } else {
        int best_rank = -1;
        for (uint32_t i = 0; i < n; i++) {
            VkPhysicalDeviceProperties p;
            vkGetPhysicalDeviceProperties(devs[i], &p);
            int rank = type_rank(p.deviceType);
            if (rank > best_rank) {
                best_rank = rank;
                chosen = (int)i;
            }
        }
    }
    if (chosen < 0) {
        rd_vk_errorf(err, errlen, "No Vulkan device matches the selector \"%s\" (%u device%s).",
                     selector, n, n == 1 ? "" : "s");
        free(devs);
        return RD_VK_ERR_DEVICE_NOT_FOUND;
    }
    vk->physical = devs[chosen];
    free(devs);
    vkGetPhysicalDeviceProperties(vk->physical, &vk->properties);
    vkGetPhysicalDeviceMemoryProperties(vk->physical, &vk->memory);
    snprintf(vk->device_name, sizeof vk->device_name, "%s", vk->properties.deviceName);
    vk->is_cpu = vk->properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
    const char *masked = getenv("PROBECAST_MASKED_LANES");
    vk->masked_lanes = masked && (strcmp(masked, "0") == 0 || strcmp(masked, "1") == 0)
                           ? strcmp(masked, "1") == 0
                           : vk->is_cpu;
    return RD_VK_OK;
}

/* ---- logical device ----------------------------------------------------------------------- */

/* Whether the physical device offers extension name. */
static bool has_device_extension(VkPhysicalDevice pd, const char *name)
{
    uint32_t n = 0;
    if (vkEnumerateDeviceExtensionProperties(pd, NULL, &n, NULL) != VK_SUCCESS) return false;
    VkExtensionProperties *props = calloc(n ? n : 1, sizeof *props);
    if (!props) abort();
    bool found = false;
    if (vkEnumerateDeviceExtensionProperties(pd, NULL, &n, props) == VK_SUCCESS)
        for (uint32_t i = 0; i < n && !found; i++)
            found = strcmp(props[i].extensionName, name) == 0;
    free(props);
    return found;
}

static rd_vk_result create_device(rd_vk *vk, const rd_vk_options *opt, char *err, size_t errlen)
{
    uint32_t api = vk->properties.apiVersion;
    if (api < VK_API_VERSION_1_2) {
        rd_vk_errorf(err, errlen, "Device \"%s\" supports Vulkan %u.%u only; 1.2 is required.",
                     vk->device_name, VK_API_VERSION_MAJOR(api), VK_API_VERSION_MINOR(api));
        return RD_VK_ERR_UNSUPPORTED;
    }

    VkPhysicalDeviceVulkan12Features has12 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
    VkPhysicalDeviceVulkan11Features has11 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES, .pNext = &has12};
    VkPhysicalDeviceFeatures2 has = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2,
                                     .pNext = &has11};
    vkGetPhysicalDeviceFeatures2(vk->physical, &has);
    const char *missing = NULL;
    if (!has12.bufferDeviceAddress)
        missing = "bufferDeviceAddress";
    else if (!has.features.shaderInt64)
        missing = "shaderInt64";
    else if (!has11.storageBuffer16BitAccess)
        missing = "storageBuffer16BitAccess";
    if (missing) {
        rd_vk_errorf(err, errlen, "Device \"%s\" lacks the required Vulkan feature %s.",
                     vk->device_name, missing);
        return RD_VK_ERR_UNSUPPORTED;
    }
    uint32_t extra = opt ? opt->extra_extension_count : 0;
    for (uint32_t i = 0; i < extra; i++) {
        if (!has_device_extension(vk->physical, opt->extra_extensions[i])) {
            rd_vk_errorf(err, errlen, "Device \"%s\" lacks the extension %s.", vk->device_name,
                         opt->extra_extensions[i]);
            return RD_VK_ERR_UNSUPPORTED;
        }
    }
    vk->has_scalar_block_layout = has12.scalarBlockLayout;
    vk->has_shader_float16 = has12.shaderFloat16;
    vk->has_shader_int16 = has.features.shaderInt16;

    /* One compute queue; a family with timestamps wins, ties go to the first. */
    uint32_t nfam = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(vk->physical, &nfam, NULL);
    VkQueueFamilyProperties *fams = calloc(nfam ? nfam : 1, sizeof *fams);
    if (!fams) abort();
    vkGetPhysicalDeviceQueueFamilyProperties(vk->physical, &nfam, fams);
    int family = -1;
    for (uint32_t i = 0; i < nfam; i++) {
        if (!(fams[i].queueFlags & VK_QUEUE_COMPUTE_BIT) || fams[i].queueCount == 0) continue;
        if (family < 0 || (fams[family].timestampValidBits == 0 && fams[i].timestampValidBits > 0))
            family = (int)i;
    }
    if (family < 0) {
        free(fams);
        rd_vk_errorf(err, errlen, "Device \"%s\" has no compute queue.", vk->device_name);
        return RD_VK_ERR_UNSUPPORTED;
    }
    vk->queue_family = (uint32_t)family;
    vk->timestamp_valid_bits = fams[family].timestampValidBits;
    free(fams);
    if (vk->timestamp_valid_bits > 0 && vk->properties.limits.timestampPeriod > 0.0f)
        vk->timestamp_period_ns = vk->properties.limits.timestampPeriod;
    else {
        vk->timestamp_valid_bits = 0;
        vk->timestamp_period_ns = 0.0;
    }

    VkPhysicalDeviceVulkan12Features en12 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES,
        .bufferDeviceAddress = VK_TRUE,
        .scalarBlockLayout = has12.scalarBlockLayout,
        .shaderFloat16 = has12.shaderFloat16,
        .pNext = opt ? opt->extra_features : NULL,
    };
    VkPhysicalDeviceVulkan11Features en11 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES,
        .pNext = &en12,
        .storageBuffer16BitAccess = VK_TRUE,
    };
    VkPhysicalDeviceFeatures2 en = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2,
        .pNext = &en11,
        .features = {.shaderInt64 = VK_TRUE, .shaderInt16 = has.features.shaderInt16},
    };
    float priority = 1.0f;
    VkDeviceQueueCreateInfo qci = {
        .sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO,
        .queueFamilyIndex = vk->queue_family,
        .queueCount = 1,
        .pQueuePriorities = &priority,
    };
    VkDeviceCreateInfo dci = {
        .sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO,
        .pNext = &en,
        .queueCreateInfoCount = 1,
        .pQueueCreateInfos = &qci,
        .enabledExtensionCount = extra,
        .ppEnabledExtensionNames = extra ? opt->extra_extensions : NULL,
    };
    VkResult r = vkCreateDevice(vk->physical, &dci, NULL, &vk->device);
    if (r != VK_SUCCESS) {
        vk->device = VK_NULL_HANDLE;
        return rd_vk_fail(vk, r, "vkCreateDevice", err, errlen);
    }
    vkGetDeviceQueue(vk->device, vk->queue_family, 0, &vk->queue);

    VkCommandPoolCreateInfo pci = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
        .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
        .queueFamilyIndex = vk->queue_family,
    };
    r = vkCreateCommandPool(vk->device, &pci, NULL, &vk->command_pool);
    if (r != VK_SUCCESS) {
        vk->command_pool = VK_NULL_HANDLE;
        return rd_vk_fail(vk, r, "vkCreateCommandPool", err, errlen);
    }
    return RD_VK_OK;
}

/* ---- public ------------------------------------------------------------------------------- */

static bool env_validation(void)
{
    const char *v = getenv("PROBECAST_VALIDATION");
    return v && *v && strcmp(v, "0") != 0;
}

rd_vk_result rd_vk_create(rd_vk *vk, const rd_vk_options *opt, char *err, size_t errlen)
{
    memset(vk, 0, sizeof *vk);
    atomic_init(&vk->validation_messages, 0u);
    pthread_mutex_init(&vk->pipelines_lock, NULL);
    rd_vk_errorf(err, errlen, "%s", "");
    rd_vk_options o = opt ? *opt : (rd_vk_options){0};
    bool validation = o.validation > 0 || (o.validation == 0 && env_validation());
    const char *selector = o.device;
    if (!selector || !*selector) selector = getenv("PROBECAST_DEVICE");
    if (selector && !*selector) selector = NULL;

    rd_vk_result rc = create_instance(vk, validation, err, errlen);
    if (rc == RD_VK_OK) rc = pick_device(vk, selector, err, errlen);
    if (rc == RD_VK_OK) rc = create_device(vk, opt, err, errlen);
    if (rc != RD_VK_OK) rd_vk_destroy(vk);
    return rc;
}

void rd_vk_destroy(rd_vk *vk)
{
    if (!vk) return;
    if (vk->device) {
        VkResult r = vkDeviceWaitIdle(vk->device);
        if (r != VK_SUCCESS) rd_vk_fail(vk, r, "vkDeviceWaitIdle", NULL, 0);
        while (vk->spare_count) {
            vk->spare_count--;
            vkDestroyFence(vk->device, vk->spare_fence[vk->spare_count], NULL);
        }
        /* the pipelines made (vk_compute.c: kept after their holders let go) */
        for (size_t i = 0; i < vk->pipeline_count; i++) {
            rd_shared_pipeline *sp = &vk->pipelines[i];
            vkDestroyPipeline(vk->device, sp->pipeline, NULL);
            vkDestroyPipelineLayout(vk->device, sp->layout, NULL);
            vkDestroyShaderModule(vk->device, sp->module, NULL);
        }
        /* the spare command buffers go with their pool */
        if (vk->command_pool) vkDestroyCommandPool(vk->device, vk->command_pool, NULL);
        vk->command_pool = VK_NULL_HANDLE;
        vkDestroyDevice(vk->device, NULL);
        vk->device = VK_NULL_HANDLE;
    }
    vk->queue = VK_NULL_HANDLE;
    vk->physical = VK_NULL_HANDLE;
    if (vk->instance) {
        if (vk->messenger) {
            PFN_vkDestroyDebugUtilsMessengerEXT destroy_messenger =
                (PFN_vkDestroyDebugUtilsMessengerEXT)vkGetInstanceProcAddr(
                    vk->instance, "vkDestroyDebugUtilsMessengerEXT");
            if (destroy_messenger) destroy_messenger(vk->instance, vk->messenger, NULL);
        }
        vkDestroyInstance(vk->instance, NULL);
    }
    vk->messenger = VK_NULL_HANDLE;
    vk->instance = VK_NULL_HANDLE;
    free(vk->pipelines);
    vk->pipelines = NULL;
    vk->pipeline_count = vk->pipeline_cap = 0;
}

void rd_vk_wait_idle(rd_vk *vk)
{
    if (vk->device && !vk->device_lost) vkDeviceWaitIdle(vk->device);
}

unsigned rd_vk_validation_messages(rd_vk *vk)
{
    return atomic_load(&vk->validation_messages);
}

rd_vk_result rd_vk_list_devices(char *out, size_t outlen, char *err, size_t errlen)
{
    if (out && outlen) out[0] = '\0';
    rd_vk tmp;
    memset(&tmp, 0, sizeof tmp);
    atomic_init(&tmp.validation_messages, 0u);
    rd_vk_result rc = create_instance(&tmp, false, err, errlen);
    VkPhysicalDevice *devs = NULL;
    uint32_t n = 0;
    if (rc == RD_VK_OK) rc = enumerate_devices(&tmp, tmp.instance, &devs, &n, err, errlen);
    size_t used = 0;
    for (uint32_t i = 0; rc == RD_VK_OK && i < n && out && outlen; i++) {
        VkPhysicalDeviceProperties p;
        vkGetPhysicalDeviceProperties(devs[i], &p);
        int w = snprintf(out + used, outlen - used, "%u: %s (%s)\n", i, p.deviceName,
                         type_name(p.deviceType));
        if (w < 0 || (size_t)w >= outlen - used) break; /* truncated */
        used += (size_t)w;
    }
    if (rc == RD_VK_OK && n == 0) {
        rd_vk_errorf(err, errlen, "The Vulkan loader reports no physical device.");
        rc = RD_VK_ERR_NO_DEVICE;
    }
    free(devs);
    rd_vk_destroy(&tmp);
    return rc;
}

void rd_vk_log_device(const rd_vk *vk, FILE *f)
{
    if (!vk->physical) {
        fprintf(f, "device: none\n");
        return;
    }
    VkPhysicalDeviceDriverProperties driver = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    VkPhysicalDeviceProperties2 p2 = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2,
                                      .pNext = &driver};
    vkGetPhysicalDeviceProperties2(vk->physical, &p2);
    uint32_t api = vk->properties.apiVersion;
    fprintf(f, "device: %s (%s), Vulkan %u.%u.%u, driver %s (%s), timestamps %s, validation %s\n",
            vk->device_name, type_name(vk->properties.deviceType), VK_API_VERSION_MAJOR(api),
            VK_API_VERSION_MINOR(api), VK_API_VERSION_PATCH(api), driver.driverName,
            driver.driverInfo, vk->timestamp_period_ns > 0 ? "yes" : "no",
            vk->validation ? "on" : "off");
}
