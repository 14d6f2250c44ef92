"""The NPMP motor module's pipeline (004 §3.3): expert rollouts -> dataset -> distillation -> one-shot imitation."""
