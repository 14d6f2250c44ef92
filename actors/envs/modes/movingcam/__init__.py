"""The movingcam mode: the dynamic-camera paper's tracking (002 section 5), root path left to physics."""
