/* Placeholder until the module lands. */
typedef int ef_plan_placeholder_t;
