"""visnav.io"""
