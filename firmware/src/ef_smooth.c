/* Placeholder until the module lands. */
typedef int ef_smooth_placeholder_t;
