"""What a run did: the tick loop's result, the typed summary, the verdict from a simulated scene's
truth, the load-profile chart, and the tree outline with a run's final statuses."""
